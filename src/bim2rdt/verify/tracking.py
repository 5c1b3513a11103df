"""Where each frame's prior comes from, through a recording (``prior_source`` in localization.json):

- ``source``: the frame carries its own pose (TUM ground truth, a bag's TF); once a fix is accepted those
  poses are odometry anchored at the last fix (as before);
- ``user``: ``--prior`` for the first frame (and until a fix is accepted);
- ``global``: no prior at all: :func:`~bim2rdt.localization.find_pose` searches the BIM. The first frame of a
  recording, every scan (each 360 degree scan on its own), and a frame after two refused fixes in a row;
- ``tracked``: the last fix (or, after a refused frame, the last prediction) composed with the frame-to-frame
  odometry (:func:`~bim2rdt.localization.odometry.icp_odometry`) of consecutive camera frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization import GlobalSearchConfig, LocalizationError, choose, find_pose, icp_odometry
from bim2rdt.perception import Frame

REFUSED_BEFORE_SEARCH = 2
"""After this many refused fixes in a row, a tracked recording is localized globally again."""
MIN_ODOMETRY_FITNESS = 0.3
"""An odometry step whose points overlap the previous frame less than this is not trusted (zero motion instead)."""


@dataclass
class Prior:
    """A frame's prior (4, 4 T_world_sensor, or None with ``reason``), where it came from, and the global search's
    candidates (JSON) when it ran."""

    pose: np.ndarray | None
    source: str
    candidates: list[dict] = field(default_factory=list)
    reason: str = ""
    odometry_fitness: float | None = None


class Tracker:
    """The prior of each frame in turn (see the module's note): ``prior(frame, points)`` before the frame is
    localized, ``update(prior, pose, accepted)`` after."""

    def __init__(self, model: BimModel, user_prior: np.ndarray | None, search: GlobalSearchConfig,
                 storey: str | None = None) -> None:
        self.model, self.search, self.storey = model, search, storey
        self.user = None if user_prior is None else np.asarray(user_prior, dtype=np.float64)
        self.anchor: tuple[np.ndarray | None, np.ndarray] | None = None if self.user is None else (None, self.user)
        self.previous_points: np.ndarray | None = None
        self.estimate: np.ndarray | None = None
        self.refused = 0
        self.own: np.ndarray | None = None
        self.anchored = False

    def prior(self, frame, points_sensor: np.ndarray) -> Prior:
        """The prior of ``frame`` (a Frame or a scan) whose points (sensor frame, m) are ``points_sensor``."""
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
