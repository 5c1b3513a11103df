"""The twin's state, folded from its history: for each element, the newest observation or missing event wins.

"Newest" is by the time the event happened, ties broken by store order, so the fold gives the same state
whatever order the events arrive in: the live twin (applying events as they are recorded, from several robots)
and a replay of the stored history up to a time agree by construction, and a test checks that they do.
"""

from __future__ import annotations

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.twin.deviation import Deviation
from bim2rdt.twin.records import MISSING, OBSERVATION, STRUCTURE, ElementState, Evidence, Fit, TwinEvent
from bim2rdt.twin.status import ElementStatus
from bim2rdt.twin.tolerance import Tolerance

STATE_KINDS = (OBSERVATION, MISSING, STRUCTURE)
"""The event kinds that set an element's state (status events record changes; safety events are history)."""


class Projection:
    """Element states folded from events; ``last_seq`` is the newest event applied."""

    def __init__(self, model: BimModel):
        self.model = model
        self.classes = {el.global_id: el.ifc_class for el in model.elements}
        self.last_seq = 0
        self._latest: dict[str, tuple[tuple[float, int], ElementState]] = {}

    def apply(self, event: TwinEvent) -> None:
        self.last_seq = max(self.last_seq, event.seq)
        if event.kind not in STATE_KINDS:
            return
        key = (event.time, event.seq)
        current = self._latest.get(event.global_id)
        if current is None or key > current[0]:
            self._latest[event.global_id] = (key, state_from_event(event, self.classes.get(event.global_id)))

    def apply_all(self, events) -> Projection:
        for event in events:
            self.apply(event)
        return self

    def get(self, global_id: str) -> ElementState | None:
        """The element's newest observed state (None if never observed)."""
        entry = self._latest.get(global_id)
        return entry[1] if entry else None

    def newest_time(self, global_id: str) -> float | None:
        entry = self._latest.get(global_id)
        return entry[0][0] if entry else None

    def outside_bim(self) -> list[ElementState]:
        """Objects the twin knows that the BIM does not (new ones, or unverified ones)."""
        return [state for _, state in self._latest.values() if not state.in_bim]

    def states(self) -> dict[str, ElementState]:
        """Every BIM element (NOT_OBSERVED where nothing was recorded) and every object the BIM lacks."""
        out = {el.global_id: ElementState(el.global_id, el.family, el.ifc_class, ElementStatus.NOT_OBSERVED)
               for el in self.model.elements}
        out.update({gid: state for gid, (_, state) in self._latest.items()})
        return out


def state_from_event(event: TwinEvent, ifc_class: str | None) -> ElementState:
    """The state an observation or missing event puts its element in (``ifc_class`` None: not in the BIM)."""
    data = event.data
    evidence = data["evidence"]
    camera = evidence.get("camera")
    bbox = evidence.get("bbox")
    return ElementState(
        global_id=event.global_id, family=data.get("family"), ifc_class=ifc_class,
        status=ElementStatus(data["status"]),
        tolerance=Tolerance(**data["tolerance"]) if data.get("tolerance") else None,
        deviation=Deviation(**data["deviation"]) if data.get("deviation") else None,
        fit=Fit(**data["fit"]) if data.get("fit") else None,
        evidence=Evidence(evidence.get("station"), tuple(evidence.get("frames", ())), event.time,
                          None if camera is None else np.asarray(camera, dtype=float),
                          None if bbox is None else tuple(bbox)),
        robot=event.source, pose=np.asarray(data["pose"], dtype=float) if data.get("pose") else None)
