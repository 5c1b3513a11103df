"""The embedded site's work schedule: the structure's tasks and the temporary works', dated around the simulated
day, written with ``ifcopenshell.api.sequence`` as a planner's 4-D tool writes them (IfcWorkSchedule, nested
IfcTask, IfcTaskTime, IfcRelAssignsToProduct, IfcRelSequence).

On the simulated day (``day``, the robot walks from 07:00 UTC):

- the slab, exterior walls, columns and interior walls were due weeks ago and are built;
- the north-east partition was due yesterday and is not built (``sim.site.UNBUILT_WALLS``): behind, the day's one
  task behind;
- the cones and the material deliveries were due yesterday and stand on site;
- setting out (the survey tripod) starts tomorrow, and the tripod is not there yet: not started;
- the scaffold is planned for the day after tomorrow but already stands: ahead, the day's one task ahead.
"""

from __future__ import annotations

from datetime import date, datetime, time, timedelta

import ifcopenshell
import ifcopenshell.api.sequence
import ifcopenshell.util.date

SCHEDULE_NAME = "Block A - construction programme"

# identification, name, (first day, last day) relative to the simulated day, products: element names or families
STRUCTURE = ("S", "Structure", (
    ("S.1", "Ground slab", (-40, -36), ("Ground Slab 250mm",)),
    ("S.2", "Exterior walls", (-35, -26), ("Exterior Wall - South", "Exterior Wall - East", "Exterior Wall - North",
                                           "Exterior Wall - West")),
    ("S.3", "Columns", (-25, -20), tuple(f"Column C{j}{i}" for j in (1, 2) for i in (1, 2, 3))),
    ("S.4", "Interior walls and door", (-19, -10), ("Interior Wall - North/South", "Interior Wall - East/West",
                                                    "Door D01")),
    ("S.5", "Partition north-east room", (-3, -1), ("Interior Wall - Partition NE",)),
))
TEMPORARY = ("T", "Temporary works", (
    ("T.1", "Traffic management (cones)", (-2, -1), ("Traffic_Cone_Orange_70cm",)),
    ("T.2", "Material deliveries", (-5, -1), ("Steel_Drum_55gal", "Wooden_Crate_1200x800x600", "Pallet_Wood_EUR",
                                              "Steel_I-Beam_W12x26_A992")),
    ("T.3", "Setting out (survey)", (1, 2), ("Survey_Tripod_Aluminium",)),
    ("T.4", "Scaffold erection", (2, 4), ("Scaffold_Frame_1000x2000",)),
))
WORK_START, WORK_END = time(7, 0), time(17, 0)
"""A working day on the site (UTC)."""


def add_site_schedule(ifc: ifcopenshell.file, day: date) -> ifcopenshell.entity_instance:
    """Add the site's work schedule to ``ifc`` (its elements already built), dated around ``day``.

    Args:
        ifc: The site's IFC file.
        day: The simulated day.

    Returns:
        The IfcWorkSchedule.
    """
    schedule = ifcopenshell.api.sequence.add_work_schedule(ifc, name=SCHEDULE_NAME, predefined_type="PLANNED",
                                                          start_time=_at(day, -40, WORK_START))
    schedule.CreationDate = ifcopenshell.util.date.datetime2ifc(_at(day, -41, WORK_START), "IfcDateTime")
    products, dated = _products_by_name(ifc), []
    for identification, name, leaves in (STRUCTURE, TEMPORARY):
        summary = ifcopenshell.api.sequence.add_task(ifc, work_schedule=schedule, name=name,
                                                     identification=identification, predefined_type="CONSTRUCTION")
        dated.append((summary, min(d[0] for *_, d, _ in leaves), max(d[1] for *_, d, _ in leaves)))
        previous = None
        for leaf_id, leaf_name, (start, finish), names in leaves:
            task = ifcopenshell.api.sequence.add_task(ifc, parent_task=summary, name=leaf_name,
                                                      identification=leaf_id, predefined_type="CONSTRUCTION")
            for product in (p for key in names for p in products.get(key, [])):
                ifcopenshell.api.sequence.assign_product(ifc, relating_product=product, related_object=task)
            if previous is not None and identification == "S":
                ifcopenshell.api.sequence.assign_sequence(ifc, relating_process=previous, related_process=task)
            dated.append((task, start, finish))
            previous = task
    for task, first, last in dated:  # after the sequences: assigning one cascades dates through the api
        _times(ifc, task, day, first, last)
    return schedule


def _products_by_name(ifc: ifcopenshell.file) -> dict[str, list[ifcopenshell.entity_instance]]:
    """{element name or family (ObjectType): elements}, in file order."""
    found: dict[str, list[ifcopenshell.entity_instance]] = {}
    for element in ifc.by_type("IfcElement"):
        for key in {element.Name, element.ObjectType} - {None}:
            found.setdefault(key, []).append(element)
    return found


def _times(ifc: ifcopenshell.file, task: ifcopenshell.entity_instance, day: date, first: int, last: int) -> None:
    """ScheduleStart at 07:00 of day ``first``, ScheduleFinish at 17:00 of day ``last`` (days from ``day``), and
    the elapsed duration between them, written as stored (the api's edit would move them to its 09:00-17:00)."""
    task_time = ifcopenshell.api.sequence.add_task_time(ifc, task=task)
    start, finish = _at(day, first, WORK_START), _at(day, last, WORK_END)
    task_time.ScheduleStart = ifcopenshell.util.date.datetime2ifc(start, "IfcDateTime")
    task_time.ScheduleFinish = ifcopenshell.util.date.datetime2ifc(finish, "IfcDateTime")
    task_time.ScheduleDuration = ifcopenshell.util.date.datetime2ifc(finish - start, "IfcDuration")
    task_time.DurationType = "ELAPSEDTIME"


def _at(day: date, offset_days: int, clock: time) -> datetime:
    return datetime.combine(day + timedelta(days=offset_days), clock)
