"""What the reader hands out: plain dataclasses with numpy poses, never ifcopenshell entities.

All lengths are metres and all poses are 4x4 float64 model-to-world matrices (world = the project's
engineering frame, z-up), whatever the file's own length unit.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

import numpy as np

Psets = dict[str, dict[str, Any]]


@dataclass(eq=False)
class BimElement:
    """One physical element (an ``IfcElement`` that is not an opening/feature, or an ``IfcSpace``).

    ``placement`` maps the element's body frame to world, metres. For exports that leave ObjectPlacement at the
    identity while the geometry sits elsewhere (Revit), it is a translation to the bottom centre of the
    tessellated bounding box and ``placement_from_geometry`` is True.
    """

    global_id: str
    ifc_class: str
    name: str | None
    family: str | None
    storey: str | None
    placement: np.ndarray
    psets: Psets = field(default_factory=dict)
    placement_from_geometry: bool = False

    @property
    def position(self) -> np.ndarray:
        """The placement's origin in world metres, (3,)."""
        return self.placement[:3, 3]


@dataclass(frozen=True)
class BimStorey:
    """A building storey; ``elevation`` in metres (None where the file leaves it unset)."""

    global_id: str
    name: str | None
    elevation: float | None


@dataclass(frozen=True)
class BimZone:
    """A space or zone the twin can attach safety data to. ``off_limits`` is the ``BIM2RDT_Zone.OffLimits``
    tag (None = untagged): the paper's model-conditioning pass asks for off-limits areas to be tagged."""

    global_id: str
    ifc_class: str
    name: str | None
    storey: str | None
    off_limits: bool | None
    kind: str | None
    member_ids: tuple[str, ...] = ()


@dataclass(frozen=True)
class BimProcess:
    """An ``IfcEvent`` or ``IfcTask`` read back from the file (times are timezone-aware UTC where known).

    ``kind`` is the event's PredefinedType (STARTEVENT, ENDEVENT, ...) or the task's PredefinedType;
    ``related`` are the GlobalIds of the products it is assigned to; ``after`` the GlobalIds of processes that
    precede it through IfcRelSequence.
    """

    global_id: str
    ifc_class: str
    name: str | None
    kind: str | None
    start: datetime | None
    finish: datetime | None
    trigger: str | None = None
    related: tuple[str, ...] = ()
    after: tuple[str, ...] = ()
    psets: Psets = field(default_factory=dict)


@dataclass(frozen=True)
class GeometryFailure:
    """An element whose geometry could not be tessellated: reported and skipped, never fatal."""

    global_id: str
    ifc_class: str
    reason: str


@dataclass(frozen=True)
class BimWarning:
    """Something wrong in the file that the reader read past: ``kind`` ("dangling reference", "parser",
    "schema"), a one-line ``message``, the STEP ids involved, and the GlobalIds of the products it affects."""

    kind: str
    message: str
    instances: tuple[int, ...] = ()
    elements: tuple[str, ...] = ()
