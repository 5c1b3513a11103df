"""What the API reads of progress: the twin's progress against its model's work schedule (the task table's rows,
the S-curve) and each permanent element's state (built / not built / not observed), now or at a past time. The
structure's judgements are read from ``structure.json`` beside the model's IFC file (where verify and the demo
write them), when there is one."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

from bim2rdt.perception.structure import permanent_elements
from bim2rdt.twin.progress import merge_statuses
from bim2rdt.twin.progress_files import curve_dict, progress_of, read_structure_statuses
from bim2rdt.twin.progress_history import twin_statuses
from bim2rdt.twin.progress_report import STATE_COLOURS, STATUS_COLOURS


class ProgressView:
    """Progress over one twin; the IFC file is parsed once, on first use. Call under the twin view's lock."""

    def __init__(self, twin, behind_percent: float = 10.0, ahead_percent: float = 10.0) -> None:
        self.twin, self.behind_percent, self.ahead_percent = twin, behind_percent, ahead_percent
        self._ifc = None

    def record(self, at: float | None = None) -> dict:
        """The progress as the dashboard draws it.

        Args:
            at: A past time, UTC seconds; None: the twin's last observation.

        Returns:
            {"progress": progress.json's document or None (no schedule), "curve": the S-curve's points,
            "groups": by storey and class (no schedule), "structure": {GlobalId: state} of the permanent elements,
            "colours": {task status: colour}, "state_colours": {built | not built | not observed: colour}}.
        """
        from bim2rdt.bim.source import read_source

        if self._ifc is None:
            self._ifc = read_source(Path(self.twin.model.path)).ifc
        structure = read_structure_statuses(Path(self.twin.model.path).parent / "structure.json")
        when = datetime.fromtimestamp(at, timezone.utc) if at is not None else None
        progress, curve, groups = progress_of(self.twin, ifc=self._ifc, at=when, structure=structure,
                                              behind_percent=self.behind_percent, ahead_percent=self.ahead_percent)
        states = merge_statuses(twin_statuses(self.twin.state(at)), structure)
        permanent = {el.global_id for el in permanent_elements(self.twin.model)}
        return {"progress": progress.to_dict() if progress is not None else None,
                "curve": curve_dict(curve)["points"], "groups": [g.to_dict() for g in groups],
                "structure": {gid: states.get(gid, "not observed") for gid in sorted(permanent)},
                "colours": STATUS_COLOURS, "state_colours": STATE_COLOURS}
