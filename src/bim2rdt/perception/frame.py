"""One RGB-D frame as a robot or a recording sends it: colour, depth, the camera's intrinsics, where the camera
was (if known), when, and which way is up.

Frames are OpenCV camera frames (x right, y down, z forward). Depth is metres along the camera z axis, with 0 or
NaN where the sensor had no return. ``T_world_camera`` (4x4) maps camera to world coordinates (world z-up,
metres). A frame is checked once, where it enters, so the stages after it can trust its shapes and units.

The pose has three states, told by ``T_world_camera`` and ``pose_is_prior``:

- known (``T_world_camera`` set, ``pose_is_prior`` False): the simulator's robot, or a frame after ``localized``;
- a prior (set, ``pose_is_prior`` True): a recording's odometry or ground truth, or a user's guess, to be fixed
  on the BIM before perception trusts it;
- absent (None): a real frame not localized yet. Code that needs a pose calls :meth:`Frame.require_pose`, which
  raises :class:`PerceptionError` in one line.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bim2rdt.frames import rigid_problem
from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.errors import PerceptionError

MAX_DEPTH_MEDIAN = 100.0
"""A median depth above this (m) is almost surely millimetres: no site RGB-D camera ranges 100 m."""


@dataclass(frozen=True)
class Frame:
    """``rgb`` (H, W, 3) uint8, ``depth`` (H, W) float32 metres (0 or NaN = no return), ``intrinsics``,
    ``T_world_camera`` (4, 4) or None (see the module's note on the pose's states), ``pose_is_prior``, ``time``
    (s, the sensor's clock) or None, ``up`` (3,): gravity's "up" as a unit vector in the camera frame (from an
    IMU) or None, and ``source``: the file, topic or renderer it came from (for messages), or None.

    Raises :class:`PerceptionError` on shapes that disagree, a depth that is not numeric or looks like
    millimetres, a pose that is not a finite rigid transform, or an ``up`` that is not a finite non-zero 3-vector.
    """

    rgb: np.ndarray
    depth: np.ndarray
    intrinsics: Intrinsics
    T_world_camera: np.ndarray | None = None
    pose_is_prior: bool = False
    time: float | None = None
    up: np.ndarray | None = None
    source: str | None = None

    def __post_init__(self) -> None:
        rgb, depth = np.asarray(self.rgb), _numeric_depth(self.depth, self._name)
        size = (self.intrinsics.height, self.intrinsics.width)
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.shape[:2] != size:
            raise PerceptionError(f"{self._name}: rgb has shape {rgb.shape}, the intrinsics say "
                                  f"({size[0]}, {size[1]}, 3)")
        if rgb.dtype != np.uint8:
            raise PerceptionError(f"{self._name}: rgb must be uint8, got {rgb.dtype}")
        if depth.shape != size:
            raise PerceptionError(f"{self._name}: depth has shape {depth.shape}, the intrinsics say {size}")
        object.__setattr__(self, "depth", depth)
        if self.T_world_camera is not None:
            object.__setattr__(self, "T_world_camera", _rigid(self.T_world_camera, self._name))
        elif self.pose_is_prior:
            raise PerceptionError(f"{self._name}: pose_is_prior is set but there is no T_world_camera")
        if self.up is not None:
            object.__setattr__(self, "up", _unit(self.up, self._name))
        if self.time is not None:
            object.__setattr__(self, "time", _seconds(self.time, self._name))
        sample = depth.reshape(-1)[:: max(1, depth.size // 4_000)]  # a 4k-pixel sample tells the unit as well
        valid = sample[np.isfinite(sample) & (sample > 0)]
        if valid.size and float(np.median(valid)) > MAX_DEPTH_MEDIAN:
            raise PerceptionError(f"{self._name}: median depth {float(np.median(valid)):.0f} looks like "
                                  "millimetres; depth must be metres")

    @property
    def _name(self) -> str:
        return f"frame {self.source}" if self.source else "frame"

    @property
    def has_pose(self) -> bool:
        """True when the pose is known (set and not a prior): what perception may trust."""
        return self.T_world_camera is not None and not self.pose_is_prior

    def require_pose(self, purpose: str = "this step") -> np.ndarray:
        """The camera's pose, for a step that cannot go on without one.

        A prior is returned too: whether to trust it is the caller's choice (``has_pose`` tells).

        Args:
            purpose: What needs the pose, named in the error.

        Returns:
            ``T_world_camera``, 4x4 camera-to-world (OpenCV camera axes), metres.

        Raises:
            PerceptionError: The frame has no pose yet; one line saying to localize it first.
        """
        if self.T_world_camera is None:
            raise PerceptionError(f"{self._name}: {purpose} needs the camera's pose (T_world_camera), and this "
                                  "frame has none yet: localize it first")
        return self.T_world_camera

    def localized(self, T_world_camera: np.ndarray) -> Frame:
        """A copy of this frame with a known pose (not a prior).

        Args:
            T_world_camera: 4x4 camera-to-world pose (OpenCV camera axes), metres.

        Returns:
            The new frame.

        Raises:
            PerceptionError: The pose is not a finite rigid 4x4 transform (the frame's own checks).
        """
        return replace(self, T_world_camera=T_world_camera, pose_is_prior=False)

    @property
    def gray(self) -> np.ndarray:
        """(H, W) uint8 luminance (ITU-R BT.601), what the corner detector reads."""
        weights = np.array([0.299, 0.587, 0.114])
        return np.clip(self.rgb @ weights + 0.5, 0, 255).astype(np.uint8)

    @property
    def valid_depth(self) -> np.ndarray:
        """(H, W) bool: pixels with a finite, positive depth return."""
        return np.isfinite(self.depth) & (self.depth > 0)


def _numeric_depth(depth, name: str) -> np.ndarray:
    array = np.asarray(depth)
    if array.dtype.kind not in "iuf":
        raise PerceptionError(f"{name}: depth must be numeric (metres), got dtype {array.dtype}")
    return array.astype(np.float32, copy=False)


def _rigid(T, name: str = "frame") -> np.ndarray:
    problem = rigid_problem(T)
    if problem is not None:
        raise PerceptionError(f"{name}: T_world_camera must be a finite 4x4 rigid pose: {problem}")
    return np.asarray(T, dtype=np.float64)


def _unit(up, name: str) -> np.ndarray:
    try:
        up = np.asarray(up, dtype=np.float64)
    except (TypeError, ValueError):
        raise PerceptionError(f"{name}: up must be a 3-vector of numbers") from None
    norm = float(np.linalg.norm(up)) if up.shape == (3,) and np.all(np.isfinite(up)) else 0.0
    if norm < 1e-9:
        raise PerceptionError(f"{name}: up must be a finite, non-zero 3-vector in the camera frame, got "
                              f"{np.asarray(up).tolist()}")
    return up / norm


def _seconds(time, name: str) -> float:
    try:
        seconds = float(time)
    except (TypeError, ValueError):
        raise PerceptionError(f"{name}: time must be seconds (a number), got {time!r}") from None
    if not np.isfinite(seconds):
        raise PerceptionError(f"{name}: time must be finite, got {seconds}")
    return seconds
