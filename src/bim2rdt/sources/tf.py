"""A TF buffer for recordings (REP 105 frames: map -> odom -> base_link -> camera optical frame), without ROS.

Edges are parent -> child transforms: static ones (``/tf_static``, valid at every time) and stamped samples
(``/tf``, or ``nav_msgs/Odometry`` when a bag has no TF). :meth:`TfBuffer.lookup` chains them from an ancestor
to a frame at a time, interpolating each stamped edge between its two samples around that time (linear in
translation, slerp in rotation), as tf2 does. A time farther than ``tolerance`` outside an edge's samples, or
in a gap between samples longer than ``max_gap``, has no transform: the caller drops the frame with the reason.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation


def matrix(translation, quaternion_xyzw) -> np.ndarray:
    """4x4 from a translation (3,) and a quaternion (x, y, z, w), ROS's order (normalised here)."""
    x, y, z, w = np.asarray(quaternion_xyzw, float) / np.linalg.norm(quaternion_xyzw)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), translation[0]],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), translation[1]],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), translation[2]],
                     [0.0, 0.0, 0.0, 1.0]])


def slerp(q0: np.ndarray, q1: np.ndarray, s: float) -> np.ndarray:
    """The unit quaternion a share ``s`` of the way from ``q0`` to ``q1`` (x, y, z, w) on the shorter arc, as
    tf2 interpolates (scipy's ``Slerp`` in a few scalar operations: it is called once per edge per frame)."""
    q0, q1 = q0 / np.linalg.norm(q0), q1 / np.linalg.norm(q1)
    dot = float(q0 @ q1)
    if dot < 0.0:
        q1, dot = -q1, -dot
    if dot > 0.9995:  # nearly the same rotation: linear, then normalised
        q = q0 + s * (q1 - q0)
        return q / np.linalg.norm(q)
    theta = np.arccos(dot)
    return (np.sin((1 - s) * theta) * q0 + np.sin(s * theta) * q1) / np.sin(theta)


def translation_quaternion(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split a rigid transform into a translation and a quaternion, ROS's way.

    Args:
        T: (4, 4) a rigid transform, metres.

    Returns:
        The translation, (3,) metres, and the unit quaternion, (4,) in ROS's order x, y, z, w.
    """
    return np.asarray(T[:3, 3], float), Rotation.from_matrix(T[:3, :3]).as_quat()


@dataclass
class _Edge:
    parent: str
    times: list[float] = field(default_factory=list)
    translations: list[np.ndarray] = field(default_factory=list)
    quaternions: list[np.ndarray] = field(default_factory=list)
    static: np.ndarray | None = None
    newest: float = -np.inf
    """The latest stamp among the samples (s)."""
    _sorted: bool = True
    _last: tuple = (None, None)
    """(time, T or reason) of the last lookup: a frame's prior and its IMU's look the same edges up at one time."""

    def add(self, time: float, translation, quaternion) -> None:
        self._last = (None, None)
        if self.times and time < self.times[-1]:
            self._sorted = False
        self.newest = max(self.newest, time)
        self.times.append(time)
        self.translations.append(np.asarray(translation, float))
        self.quaternions.append(np.asarray(quaternion, float))

    def at(self, time: float, tolerance: float, max_gap: float) -> np.ndarray | str:
        """T_parent_child at ``time``, or why not (a sentence)."""
        if self.static is not None:
            return self.static
        if self._last[0] == time:
            return self._last[1]
        found = self._at(time, tolerance, max_gap)
        self._last = (time, found)
        return found

    def _at(self, time: float, tolerance: float, max_gap: float) -> np.ndarray | str:
        if not self._sorted:
            order = np.argsort(self.times, kind="stable")
            self.times = [self.times[i] for i in order]
            self.translations = [self.translations[i] for i in order]
            self.quaternions = [self.quaternions[i] for i in order]
            self._sorted = True
        times = self.times
        i = bisect.bisect_left(times, time)
        if i < len(times) and abs(times[i] - time) <= 1e-9:
            return matrix(self.translations[i], self.quaternions[i])
        if i == 0 or i == len(times):
            nearest = 0 if i == 0 else len(times) - 1
            if abs(times[nearest] - time) > tolerance:
                return f"{abs(times[nearest] - time) * 1000:.0f} ms from its nearest sample"
            return matrix(self.translations[nearest], self.quaternions[nearest])
        t0, t1 = times[i - 1], times[i]
        if t1 - t0 > max_gap and min(time - t0, t1 - time) > tolerance:
            return f"in a {t1 - t0:.2f} s gap between samples"
        s = (time - t0) / (t1 - t0)
        return matrix((1 - s) * self.translations[i - 1] + s * self.translations[i],
                      slerp(self.quaternions[i - 1], self.quaternions[i], s))


TRIM_BATCH = 64
"""Samples an edge sheds at once when old ones are forgotten (trimming a list one sample at a time is quadratic)."""


class TfBuffer:
    """Transforms between a recording's frames over time (see the module's note); frame ids are compared
    without a leading '/' (ROS 1 style).

    :meth:`forget_before` costs what it removes, not the number of frames: it visits only the edges that hold
    more than :data:`TRIM_BATCH` samples, and the edges updated longest ago (a recording that names 10^6 frames
    once each made it quadratic: 20k frames took 67 s)."""

    def __init__(self, tolerance: float = 0.02, max_gap: float = 0.5) -> None:
        self.tolerance, self.max_gap = tolerance, max_gap
        self._edges: dict[str, _Edge] = {}
        self._long: set[str] = set()
        """Children whose edge holds more than TRIM_BATCH + 2 samples: the only ones worth trimming."""
        self._updated: dict[str, None] = {}
        """Children of stamped edges, least recently updated first (a dict keeps insertion order)."""

    def add(self, parent: str, child: str, translation, quaternion_xyzw, time: float | None) -> None:
        """One transform T_parent_child (``time`` None: static)."""
        parent, child = _name(parent), _name(child)
        edge = self._edges.get(child)
        if edge is None or edge.parent != parent:
            edge = self._edges[child] = _Edge(parent)
        if time is None:
            edge.static = matrix(translation, quaternion_xyzw)
            return
        edge.add(time, translation, quaternion_xyzw)
        self._updated.pop(child, None)
        self._updated[child] = None
        if len(edge.times) > TRIM_BATCH + 2:
            self._long.add(child)

    def add_matrix(self, parent: str, child: str, T_parent_child: np.ndarray, time: float | None = None) -> None:
        """One transform given as a 4x4."""
        translation, quaternion = translation_quaternion(T_parent_child)
        self.add(parent, child, translation, quaternion, time)

    def statics(self) -> list[tuple[str, str, np.ndarray]]:
        """(parent, child, T_parent_child) of every static transform."""
        return [(edge.parent, child, edge.static) for child, edge in self._edges.items() if edge.static is not None]

    def forget_before(self, time: float) -> None:
        """Drop stamped samples older than ``time`` (keeping each edge's last two), and stamped edges whose every
        sample is older (no lookup at or after ``time`` can use them): memory flat while streaming."""
        while self._updated:
            child = next(iter(self._updated))
            edge = self._edges.get(child)
            if edge is not None and edge.newest >= time:
                break
            del self._updated[child]
            self._long.discard(child)
            if edge is not None and edge.static is None:
                del self._edges[child]
        for child in list(self._long):
            edge = self._edges[child]
            cut = bisect.bisect_left(edge.times, time) if edge._sorted else 0
            cut = min(cut, max(0, len(edge.times) - 2))
            if cut > TRIM_BATCH:
                del edge.times[:cut], edge.translations[:cut], edge.quaternions[:cut]
                edge._last = (None, None)
            if len(edge.times) <= TRIM_BATCH + 2:
                self._long.discard(child)

    @property
    def frames(self) -> set[str]:
        return set(self._edges) | {e.parent for e in self._edges.values()}

    def __bool__(self) -> bool:
        return bool(self._edges)

    def chain(self, frame: str) -> list[str]:
        """``frame`` and its ancestors up to the root of its tree (in a cycle: up to the first frame met twice,
        which ends the list; :meth:`cycle`)."""
        names, seen = [_name(frame)], set()
        while names[-1] in self._edges and names[-1] not in seen:
            seen.add(names[-1])
            names.append(self._edges[names[-1]].parent)
        return names

    def cycle(self, frame: str) -> list[str] | None:
        """The loop among ``frame``'s ancestors (its first frame repeated at the end), or None in a tree: TF is a
        tree, and a loop gives no root to put poses in."""
        chain = self.chain(frame)
        return chain[chain.index(chain[-1]):] if chain[-1] in chain[:-1] else None

    def root(self, frame: str, preferred: tuple[str, ...] = ("map", "odom")) -> str:
        """The frame poses of ``frame`` are given in: the first of ``preferred`` among its ancestors, else the
        root of its tree."""
        chain = self.chain(frame)
        return next((p for p in preferred if p in chain), chain[-1])

    def lookup(self, target: str, frame: str, time: float) -> np.ndarray | str:
        """T_target_frame (4x4) at ``time``, or a sentence saying why there is none (no path, or no sample of an
        edge within the tolerance)."""
        target, frame = _name(target), _name(frame)
        loop = self.cycle(frame)
        if loop is not None:
            return f"TF cycle {' -> '.join(loop)}"
        chain = self.chain(frame)
        if target not in chain:
            return f"no TF path from '{target}' to '{frame}'"
        T = np.eye(4)
        for child in chain[: chain.index(target)]:
            edge = self._edges[child]
            step = edge.at(time, self.tolerance, self.max_gap)
            if isinstance(step, str):
                return f"no TF {edge.parent} -> {child} within {self.tolerance * 1000:.0f} ms ({step})"
            T = step @ T
        return T


def _name(frame: str) -> str:
    return frame.lstrip("/")


def listed(frames, limit: int = 20) -> str:
    """Frame names for an error line: the first ``limit`` sorted, then how many more (a bag may name 10^6)."""
    names = sorted(frames)
    more = f" and {len(names) - limit} more" if len(names) > limit else ""
    return ", ".join(names[:limit]) + more
