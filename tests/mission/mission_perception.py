"""The mission tests' eyes on a simulated site (a test double, not the demo's perception): render the real site from
the robot's camera (with sensor noise), and for every object in view hand its family label and ROI corner points
to the mission, nothing more."""

from __future__ import annotations

import numpy as np

from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.detection import Detection
from bim2rdt.perception.frame import Frame
from bim2rdt.sim.reality import Reality
from bim2rdt.sim.render import RgbdFrame, render_rgbd
from bim2rdt.sim.views import object_scene_points


class SimulatedPerception:
    """The perception front end on simulated frames: render the real site from the robot's camera (with sensor
    noise), and for every object in view hand its family label and ROI corner points to the mission, nothing
    more: which true object a detection was is for the scoring to find out afterwards, by geometry.

    The detector here is the renderer's instance mask with the true family (an ideal open-vocabulary detector);
    everything after the ROI (Shi-Tomasi corners, depth, back-projection, clutter) is the real pipeline."""

    def __init__(self, reality: Reality, intrinsics: Intrinsics = Intrinsics(), seed: int = 0,
                 min_pixels: int = 150):
        self.reality, self.intrinsics, self.min_pixels = reality, intrinsics, min_pixels
        self.rng = np.random.default_rng(seed)
        self.frames: list[RgbdFrame] = []
        self._latest: dict[int, RgbdFrame] = {}

    def __call__(self, station: int, T_world_camera: np.ndarray) -> list[Detection]:
        frame = render_rgbd(self.reality.scene, self.intrinsics, T_world_camera, self.rng)
        self.frames.append(frame)
        self._latest[station] = frame
        seen, pixels = np.unique(frame.labels[frame.labels >= 0], return_counts=True)
        return [Detection(self.reality.truth[index].family,
                          object_scene_points(frame, self.intrinsics, int(index), self.rng), station)
                for index, count in zip(seen, pixels) if count >= self.min_pixels]

    def station_frame(self, station: int) -> Frame | None:
        """The last frame taken for ``station`` as a robot sends it (no labels): the mission's ``frame_of``."""
        frame = self._latest.get(station)
        return None if frame is None else frame.as_frame(self.intrinsics)
