"""IFC in and out, with ifcopenshell: ``load_ifc`` reads a file into a ``BimModel`` of ``BimElement`` records
and world-metre meshes; ``TwinWriter`` writes the twin (moves, observed objects, events, tasks) back;
``read_work_schedule`` reads a 4-D schedule (``WorkSchedule`` of ``ScheduledTask``) and ``product_quantities``
how much of each product there is (``Quantities``)."""

from bim2rdt.bim.errors import BimError
from bim2rdt.bim.map_classes import NO_MAP, map_elements
from bim2rdt.bim.model import BimModel, load_ifc
from bim2rdt.bim.quantities import Quantities, product_quantities
from bim2rdt.bim.schedule import ScheduledTask, WorkSchedule, read_work_schedule, read_work_schedules
from bim2rdt.bim.records import BimElement, BimProcess, BimStorey, BimWarning, BimZone, GeometryFailure
from bim2rdt.bim.site_frame import SiteFrame
from bim2rdt.bim.source import read_source

__all__ = ["NO_MAP", "BimError", "BimModel", "BimElement", "BimProcess", "BimStorey", "BimWarning", "BimZone",
           "GeometryFailure", "Quantities", "ScheduledTask", "SiteFrame", "TwinWriter", "WorkSchedule", "load_ifc",
           "map_elements", "product_quantities", "read_source", "read_work_schedule", "read_work_schedules"]


def __getattr__(name: str):
    if name == "TwinWriter":
        from bim2rdt.bim.writer import TwinWriter

        return TwinWriter
    raise AttributeError(name)
