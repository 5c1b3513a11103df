"""What a caller may tell a frame reader, checked once where it enters (``open_source(path, **options)``)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from bim2rdt.perception import Intrinsics
from bim2rdt.sources.calibration import correction_vector
from bim2rdt.sources.errors import SourceError


@dataclass(frozen=True)
class SourceOptions:
    """``intrinsics``: the camera's, overriding what the recording says (an :class:`Intrinsics`, or a dict of its
    fields: fx, fy, cx, cy, and width/height when they differ from the images); ``depth_scale``: raw depth units
    per metre (TUM 5000, millimetre sensors 1000), overriding the format's own; ``depth_correction``: g (gx, gy,
    gz) in 1/m, see :mod:`bim2rdt.sources.calibration`; ``prior``: a 4x4 T_world_camera given to every frame as
    its prior pose (a recording's own poses win, e.g. TUM's groundtruth.txt); ``up``: gravity up in the camera
    frame for every frame, overriding an IMU; ``calibration``: a JSON file with an Azure Kinect's calibration
    (instead of the one attached to the .mkv); ``max_frames``: stop after this many frames; ``every``: keep every
    N-th frame; ``topics``: a bag's topics by role (a dict, or ``"colour=/a,depth=/b"``; roles in
    :data:`TOPIC_ROLES`), the others found by message type; ``sync_tolerance``: seconds within which a bag's
    colour, depth and TF samples belong to one frame (default 0.02)."""

    intrinsics: Intrinsics | dict | None = None
    depth_scale: float | None = None
    depth_correction: np.ndarray | None = None
    prior: np.ndarray | None = None
    up: np.ndarray | None = None
    calibration: Path | None = None
    max_frames: int | None = None
    every: int | None = None
    topics: dict | None = None
    sync_tolerance: float | None = None


TOPIC_ROLES = ("colour", "depth", "camera_info", "imu", "odometry")
"""What a bag's topic may be named for with ``topics``."""


def parse_options(path, options: dict) -> SourceOptions:
    """``options`` as :class:`SourceOptions`, or :class:`SourceError` naming the option that is unknown or bad."""
    known = {f.name for f in fields(SourceOptions)}
    unknown = sorted(set(options) - known)
    if unknown:
        raise SourceError(path, f"unknown source option {unknown[0]!r} (known: {', '.join(sorted(known))})")
    values = {k: v for k, v in options.items() if v is not None}
    try:
        return SourceOptions(**{name: _CHECKS[name](value) for name, value in values.items()})
    except (TypeError, ValueError) as error:
        raise SourceError(path, str(error)) from None


def _intrinsics(value) -> Intrinsics | dict:
    if isinstance(value, Intrinsics):
        return value
    if isinstance(value, dict):
        allowed = {"fx", "fy", "cx", "cy", "width", "height"}
        if not {"fx", "fy", "cx", "cy"} <= set(value) or set(value) - allowed:
            raise ValueError(f"intrinsics needs fx, fy, cx, cy (and optionally width, height), got {sorted(value)}")
        return value
    raise ValueError(f"intrinsics must be an Intrinsics or a dict of fx, fy, cx, cy, got {type(value).__name__}")


def _positive(name: str):
    def check(value) -> float:
        number = float(value)
        if not np.isfinite(number) or number <= 0:
            raise ValueError(f"{name} must be a positive number, got {value!r}")
        return number
    return check


def _pose(value) -> np.ndarray:
    T = np.asarray(value, dtype=np.float64)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise ValueError(f"prior must be a finite 4x4 T_world_camera, got shape {T.shape}")
    return T


def _up(value) -> np.ndarray:
    up = np.asarray(value, dtype=np.float64)
    if up.shape != (3,) or not np.all(np.isfinite(up)) or np.linalg.norm(up) < 1e-9:
        raise ValueError(f"up must be a finite non-zero (x, y, z) in the camera frame, got {up.tolist()}")
    return up / np.linalg.norm(up)


def _whole(name: str):
    def check(value) -> int:
        if int(value) != value or value < 1:
            raise ValueError(f"{name} must be a positive whole number, got {value!r}")
        return int(value)
    return check


def _topics(value) -> dict:
    if isinstance(value, str):
        pairs = [item.split("=", 1) for item in value.split(",") if item.strip()]
        if any(len(pair) != 2 for pair in pairs):
            raise ValueError(f"topics needs ROLE=/topic pairs separated by commas, got {value!r}")
        value = {role.strip(): topic.strip() for role, topic in pairs}
    if not isinstance(value, dict):
        raise ValueError(f"topics must be a dict of role -> topic, got {type(value).__name__}")
    value = {"colour" if role == "color" else role: topic for role, topic in value.items()}
    unknown = sorted(set(value) - set(TOPIC_ROLES))
    if unknown:
        raise ValueError(f"unknown topic role {unknown[0]!r} (roles: {', '.join(TOPIC_ROLES)})")
    return {role: "/" + str(topic).lstrip("/") for role, topic in value.items()}


_CHECKS = {"intrinsics": _intrinsics, "depth_scale": _positive("depth_scale"), "depth_correction": correction_vector,
           "prior": _pose, "up": _up, "calibration": Path, "max_frames": _whole("max_frames"), "every": _whole("every"),
           "topics": _topics, "sync_tolerance": _positive("sync_tolerance")}
