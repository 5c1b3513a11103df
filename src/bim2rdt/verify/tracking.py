"""Where each frame's prior comes from, through a recording (``prior_source`` in localization.json):

- ``source``: the frame carries its own pose (TUM ground truth, a bag's TF); once a fix is accepted those
  poses are odometry anchored at the last fix (as before). With ``own_poses="odometry"`` (a robot's ``map`` or
  ``odom`` frame never aligned to the BIM) they are only ever odometry: the first frame is found globally, and
  after a fix the next frame's prior is that fix moved by the own poses' step (also ``source``);
- ``user``: ``--prior`` for the first frame (and until a fix is accepted);
- ``global``: no prior at all: :func:`~bim2rdt.localization.find_pose` searches the BIM. The first frame of a
  recording, every scan (each 360 degree scan on its own), and a frame after two refused fixes in a row. When
  the view is ambiguous, its places are carried frame to frame by the odometry (the own poses', or ICP's)
  until one is left (:class:`~bim2rdt.localization.Sweep`); the frames seen meanwhile are held (at most
  ``HELD_FRAMES``), and once the sweep is resolved they are verified from the resolved pose carried back
  through the odometry. Such frames list ``places`` (how many places were left: 1) and ``resolved_at`` (the
  frame index at which the ambiguity was resolved); a frame refused while several places fit lists ``places``;
- ``tracked``: the last fix (or, after a refused frame, the last prediction) composed with the frame-to-frame
  odometry (:func:`~bim2rdt.localization.odometry.icp_odometry`) of consecutive camera frames.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization import GlobalSearchConfig, LocalizationError, Sweep, choose, find_pose, icp_odometry
from bim2rdt.perception import Frame

REFUSED_BEFORE_SEARCH = 2
"""After this many refused fixes in a row, a tracked recording is localized globally again."""
MIN_ODOMETRY_FITNESS = 0.3
"""An odometry step whose points overlap the previous frame less than this is not trusted (zero motion instead)."""
HELD_FRAMES = 8
"""At most this many frames wait while the view is ambiguous (a VGA frame and its points: ~10 MB each); an older
one is verified as refused."""
OWN_POSES = ("world", "odometry")
"""How a recording's own poses are read: in the model's frame until a fix is accepted (``world``), or as odometry
only, in a frame never aligned to the BIM (``odometry``)."""


@dataclass
class Prior:
    """A frame's prior (4, 4 T_world_sensor, or None with ``reason``), where it came from, and the global search's
    candidates (JSON) when it ran; ``places`` how many places fit when the sweep's hypotheses were carried to
    this frame, ``resolved_at`` the frame index at which they came down to one."""

    pose: np.ndarray | None
    source: str
    candidates: list[dict] = field(default_factory=list)
    reason: str = ""
    odometry_fitness: float | None = None
    places: int | None = None
    resolved_at: int | None = None


@dataclass
class _Held:
    index: int
    number: int
    frame: object
    points: np.ndarray
    prior: Prior


class Tracker:
    """The prior of each frame in turn (see the module's note): ``push(frame, points)`` gives the frames ready to
    be localized with their priors, in order (none while the view is ambiguous and the frame is held, several
    when a sweep is resolved), ``flush()`` the held ones at the end, and ``update(prior, pose, accepted)`` is
    called after each is localized."""

    def __init__(self, model: BimModel, user_prior: np.ndarray | None, search: GlobalSearchConfig,
                 storey: str | None = None, own_poses: str = "world", hold: int = HELD_FRAMES) -> None:
        if own_poses not in OWN_POSES:
            raise ValueError(f"own_poses must be one of {OWN_POSES}, not {own_poses!r}")
        self.model, self.search, self.storey, self.own_poses = model, search, storey, own_poses
        self.user = None if user_prior is None else np.asarray(user_prior, dtype=np.float64)
        self.anchor: tuple[np.ndarray | None, np.ndarray] | None = None if self.user is None else (None, self.user)
        self.previous_points: np.ndarray | None = None
        self.previous_own: np.ndarray | None = None
        self.estimate: np.ndarray | None = None
        self.refused = 0
        self.own: np.ndarray | None = None
        self.anchored = False
        self.sweep = Sweep(model, search, storey, hold=hold)
        self.held: deque[_Held] = deque()
        self.hold, self.count = hold, 0

    def push(self, frame, points_sensor: np.ndarray) -> list[tuple[int, object, np.ndarray, Prior]]:
        """The frames ready to localize after ``frame`` (a Frame or a scan) arrives, with their priors, in order.

        Args:
            frame: The next frame or scan of the recording.
            points_sensor: Its points (sensor frame, m).

        Returns:
            (its index in the recording, frame, its points, its prior) for each frame now ready: none while
                ``frame`` is held.
        """
        index, self.count = self.count, self.count + 1
        camera = isinstance(frame, Frame)
        own = frame.T_world_camera if camera else None
        if self.user is not None or not camera or (own is not None and self.own_poses == "world"):
            return [(index, frame, points_sensor, self.prior(frame, points_sensor))]
        self.anchored = False
        step, fitness = self._step(own, points_sensor)
        if self.estimate is not None and self.refused < REFUSED_BEFORE_SEARCH:
            source = "tracked" if own is None else "source"
            moved = self.estimate if step is None else self.estimate @ step
            return [(index, frame, points_sensor, Prior(moved, source, odometry_fitness=fitness))]
        return self._swept(index, frame, points_sensor, step)

    def flush(self) -> list[tuple[int, object, np.ndarray, Prior]]:
        """The frames still held at the end of the recording (the view stayed ambiguous): refused, in order."""
        out = [(h.index, h.frame, h.points, h.prior) for h in self.held]
        self.held.clear()
        return out

    def prior(self, frame, points_sensor: np.ndarray) -> Prior:
        """The prior of ``frame`` (a Frame or a scan) whose points (sensor frame, m) are ``points_sensor``, when its
        own poses are in the model's frame or a user prior is given (no frame is held)."""
        camera = isinstance(frame, Frame)
        self.own = frame.T_world_camera if camera else None
        self.anchored = self.own is not None or (self.user is not None and not camera)
        if self.anchored:
            return self._anchored()
        if not camera:
            return self._global(frame)
        previous, self.previous_points = self.previous_points, points_sensor
        if self.estimate is None and self.user is not None:
            return Prior(self.user, "user")
        if self.estimate is None or self.refused >= REFUSED_BEFORE_SEARCH:
            return self._global(frame)
        step = icp_odometry(previous, points_sensor)
        if step.fitness < MIN_ODOMETRY_FITNESS:
            return Prior(self.estimate, "tracked", odometry_fitness=step.fitness)
        return Prior(self.estimate @ step.T_previous_current, "tracked", odometry_fitness=step.fitness)

    def update(self, prior: Prior, pose: np.ndarray | None, accepted: bool) -> None:
        """What the frame's fix gave: the estimate the next frame is tracked from, the refusals in a row, and
        the anchor of a source's own poses."""
        if self.anchored:
            if accepted:
                self.anchor = (self.own, pose)
            elif self.anchor is not None and self.anchor[0] is None and self.own is not None:
                self.anchor = (self.own, self.anchor[1])  # the user's prior is where the sensor was at its first pose
        self.refused = 0 if accepted else self.refused + 1
        self.estimate = pose if accepted else prior.pose

    def _step(self, own: np.ndarray | None, points_sensor: np.ndarray) -> tuple[np.ndarray | None, float | None]:
        """The odometry from the previous camera frame (4, 4 T_previous_current): the own poses' step, else ICP
        (identity when it overlaps too little); None for the first frame. Only computed when it is needed: while
        tracking or carrying places."""
        previous_points, self.previous_points = self.previous_points, points_sensor
        previous_own, self.previous_own = self.previous_own, own
        needed = (self.estimate is not None and self.refused < REFUSED_BEFORE_SEARCH) or bool(self.sweep.places)
        if not needed:
            return None, None
        if own is not None and previous_own is not None:
            return np.linalg.inv(previous_own) @ own, None
        if previous_points is None or own is not None:
            return None, None
        step = icp_odometry(previous_points, points_sensor)
        if step.fitness < MIN_ODOMETRY_FITNESS:
            return np.eye(4), step.fitness
        return step.T_previous_current, step.fitness

    def _swept(self, index: int, frame, points_sensor: np.ndarray, step: np.ndarray | None
               ) -> list[tuple[int, object, np.ndarray, Prior]]:
        """The frame given to the sweep: taken (with the held frames back-filled), held while places are
        carried, or refused."""
        number = self.sweep.count
        result = self.sweep.add(frame, step if self.sweep.places else None)
        listed = [c.to_json() for c in result.candidates]
        if result.pose is not None:
            by_number = dict(result.backfill)
            out = [(h.index, h.frame, h.points, Prior(by_number[h.number], "global", h.prior.candidates, places=1,
                                                      resolved_at=index)
                    if h.number in by_number else h.prior) for h in self.held]
            self.held.clear()
            self.sweep.reset()
            resolved = index if result.resolved_at is not None else None
            return out + [(index, frame, points_sensor, Prior(result.pose, "global", listed, places=len(result.places),
                                                       resolved_at=resolved))]
        refused = Prior(None, "global", listed, result.reason, places=len(result.places) or None)
        if not self.sweep.places:
            out = self.flush()
            return out + [(index, frame, points_sensor, refused)]
        self.held.append(_Held(index, number, frame, points_sensor, refused))
        out = []
        while len(self.held) > self.hold:
            oldest = self.held.popleft()
            out.append((oldest.index, oldest.frame, oldest.points, oldest.prior))
        return out

    def _anchored(self) -> Prior:
        """A source's own poses, or a user's prior for scans, anchored at the last accepted fix."""
        if self.anchor is None:
            return Prior(self.own, "source")
        anchor_own, anchor_world = self.anchor
        if self.own is None or anchor_own is None:  # no odometry to carry the anchor forward (or the first frame)
            return Prior(anchor_world, "user" if anchor_world is self.user else "tracked")
        return Prior(anchor_world @ np.linalg.inv(anchor_own) @ self.own, "source")

    def _global(self, frame) -> Prior:
        try:
            candidates = find_pose(frame, self.model, config=self.search, storey=self.storey)
        except LocalizationError as error:
            return Prior(None, "global", reason=f"global search: {error}")
        best, reason = choose(candidates, self.search)
        listed = [c.to_json() for c in candidates]
        if best is None:
            return Prior(None, "global", listed, reason)
        return Prior(best.pose, "global", listed)
