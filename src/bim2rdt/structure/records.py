"""What the structure judge takes and gives: a view (points and the fixed pose) and one judgement per permanent
element, and ``structure.json`` (a list of judgements) that verify and the demo write."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.structure.errors import StructureError

AS_PLANNED, DEVIATING, NOT_BUILT, NOT_OBSERVED = "as planned", "deviating", "not built", "not observed"
STRUCTURE_STATUSES = (AS_PLANNED, DEVIATING, NOT_BUILT, NOT_OBSERVED)
"""The statuses of a permanent element, as structure.json and progress.json spell them."""


@dataclass(frozen=True)
class StructureView:
    """One frame or scan as the judge sees it: ``index`` (the frame's), ``points_sensor`` (N, 3) in the sensor
    frame (metres; NaN rows are no return) and ``pose`` (4, 4) T_world_sensor, the BIM-fixed pose."""

    index: int
    points_sensor: np.ndarray
    pose: np.ndarray

    def __post_init__(self) -> None:
        points = np.asarray(self.points_sensor, dtype=np.float64)
        pose = np.asarray(self.pose, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise StructureError(f"view {self.index}: points_sensor must be (N, 3) metres, got {points.shape}")
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise StructureError(f"view {self.index}: pose must be a finite 4x4 T_world_sensor, got {pose.shape}")
        object.__setattr__(self, "points_sensor", points)
        object.__setattr__(self, "pose", pose)


@dataclass(frozen=True)
class StructureJudgement:
    """One permanent element judged: ``status`` (one of :data:`STRUCTURE_STATUSES`), ``coverage`` (0-1, the share
    of its sensor-facing surface the data covers), ``median_mm`` (signed: + where the built surface stands proud of
    the model face, towards the sensor) and ``p95_mm`` (of the distances' magnitudes) of the returns on its faces,
    ``offset_m`` (x, y, z world, m: zero along what its faces do not pin; None when no face pins any) and
    ``rotation_deg`` (its faces' tilt against the model's; None when no face is large enough), the ``frames`` that
    saw it, ``reason``: why this status, and ``built_share`` (0-1: the share of its face in clear view not seen
    through; 0 when not built, 1 when as planned or deviating by its offset or tilt; None when not observed), which
    progress weighs the element's quantity by."""

    global_id: str
    ifc_class: str
    status: str
    coverage: float
    median_mm: float | None = None
    p95_mm: float | None = None
    offset_m: tuple[float, float, float] | None = None
    rotation_deg: float | None = None
    frames: list[int] = field(default_factory=list)
    reason: str = ""
    built_share: float | None = None

    def to_dict(self) -> dict:
        """The judgement as structure.json holds it.

        Returns:
            {field: value} with exactly the dataclass's fields; lengths in mm or m as named, angles in degrees.
        """
        return {"global_id": self.global_id, "ifc_class": self.ifc_class, "status": self.status,
                "coverage": self.coverage, "median_mm": self.median_mm, "p95_mm": self.p95_mm,
                "offset_m": None if self.offset_m is None else list(self.offset_m),
                "rotation_deg": self.rotation_deg, "frames": list(self.frames), "reason": self.reason,
                "built_share": self.built_share}

    @classmethod
    def from_dict(cls, data: dict) -> StructureJudgement:
        """A judgement from its :meth:`to_dict` form.

        Args:
            data: One entry of structure.json.

        Returns:
            The judgement.

        Raises:
            StructureError: A missing field or an unknown status (``built_share`` may be absent: None).
        """
        try:
            judgement = cls(data["global_id"], data["ifc_class"], data["status"], float(data["coverage"]),
                            data["median_mm"], data["p95_mm"],
                            None if data["offset_m"] is None else tuple(float(v) for v in data["offset_m"]),
                            data["rotation_deg"], [int(f) for f in data["frames"]], data["reason"],
                            None if data.get("built_share") is None else float(data["built_share"]))
        except (KeyError, TypeError, ValueError) as error:
            raise StructureError(f"a structure judgement needs every field of StructureJudgement: {error}") from None
        if judgement.status not in STRUCTURE_STATUSES:
            raise StructureError(f"unknown structure status {judgement.status!r} (one of {STRUCTURE_STATUSES})")
        return judgement


def write_structure_json(judgements: list[StructureJudgement], path: Path) -> Path:
    """Write ``structure.json`` (a JSON list of :meth:`StructureJudgement.to_dict`) atomically.

    Args:
        judgements: The judgements, in model order.
        path: The file to write.

    Returns:
        The written path.
    """
    entries = [_finite(j.to_dict()) for j in judgements]
    return write_bytes_atomic(Path(path), json.dumps(entries, indent=1).encode())


def read_structure_json(path: Path) -> list[StructureJudgement]:
    """The judgements a ``structure.json`` holds.

    Args:
        path: The file verify or the demo wrote.

    Returns:
        Its judgements, in file order.

    Raises:
        StructureError: The file cannot be read or is not a list of judgements.
    """
    try:
        entries = json.loads(Path(path).read_text())
    except (OSError, ValueError) as error:
        raise StructureError(f"{path}: {str(error).splitlines()[0]}") from None
    if not isinstance(entries, list):
        raise StructureError(f"{path}: expected a JSON list of structure judgements")
    return [StructureJudgement.from_dict(entry) for entry in entries]


def _finite(entry: dict) -> dict:
    """NaN or inf (nothing measured) as None: JSON has no NaN."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in entry.items()}
