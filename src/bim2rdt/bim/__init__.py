"""IFC in and out, with ifcopenshell: ``load_ifc`` reads a file into a ``BimModel`` of ``BimElement`` records
and world-metre meshes; ``TwinWriter`` writes the twin (moves, observed objects, events, tasks) back."""

from bim2rdt.bim.errors import BimError
from bim2rdt.bim.map_classes import NO_MAP, map_elements
from bim2rdt.bim.model import BimModel, load_ifc
from bim2rdt.bim.records import BimElement, BimProcess, BimStorey, BimWarning, BimZone, GeometryFailure
from bim2rdt.bim.site_frame import SiteFrame

__all__ = ["NO_MAP", "BimError", "BimModel", "BimElement", "BimProcess", "BimStorey", "BimWarning", "BimZone",
           "GeometryFailure", "SiteFrame", "TwinWriter", "load_ifc", "map_elements"]


def __getattr__(name: str):
    if name == "TwinWriter":
        from bim2rdt.bim.writer import TwinWriter

        return TwinWriter
    raise AttributeError(name)
