"""The demo robot's eyes: the simulated RGB-D camera inside the building, and the detector that reads its frames.

Each station's frame is rendered as a robot would send it (the IFC's building around the objects, RGB, time-of-
flight flying pixels and dropouts, a worker walking through some frames), then handed to the chosen detector
(:mod:`bim2rdt.perception.detectors`: ``geometric`` by default, ``yoloe``, or ``ideal``, the renderer's own masks
with the true families: the upper bound, for comparison only).

Objects perception cannot name ("unknown": a worker, clutter) are not registered against the BIM: they are not
site objects the BIM could have, and must not become phantom proxies in the twin.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.perception import (UNKNOWN_FAMILY, Detection, Frame, Intrinsics, PerceptionConfig,
                                locate_detections)
from bim2rdt.perception.detectors import make_detector
from bim2rdt.semantics import UprightPrior
from bim2rdt.sim.ideal import IdealDetector
from bim2rdt.sim.reality import Reality
from bim2rdt.sim.render import RgbdFrame, render_rgbd
from bim2rdt.sim.scene import SiteScene
from bim2rdt.sim.tof import TofEffects
from bim2rdt.sim.workers import worker_in_view

WORKER_FRACTION = 0.3
"""Share of the demo's frames a worker walks through."""
log = logging.getLogger(__name__)


class DemoPerception:
    """``perceive(station, T_world_camera) -> detections with world points``, the mission's callback: renders
    the station's frame and runs the detector on it. ``frames`` keeps every rendered frame, ``unknown`` counts
    the detections left unnamed (workers among them)."""

    def __init__(self, detector: str, model: BimModel, reality: Reality, priors: dict[str, UprightPrior],
                 seed: int = 0, yoloe: tuple[Path, Path] | None = None, intrinsics: Intrinsics = Intrinsics(),
                 config: PerceptionConfig = PerceptionConfig()):
        self.model, self.reality, self.intrinsics, self.config = model, reality, intrinsics, config
        self.detector = make_detector(detector, model, priors, yoloe,
                                      ideal=lambda: IdealDetector([t.family for t in reality.truth]),
                                      geometric=config.geometric)
        self.rng = np.random.default_rng([seed, 5])
        self.frames: list = []
        self.unknown = 0
        self._latest: dict[int, Frame] = {}
        building = reality.scene.building
        self._footprints = [p.mesh.bounds[:, :2].ravel() for p in building if p.ifc_class != "IfcSlab"]

    def __call__(self, station: int, T_world_camera: np.ndarray) -> list[Detection]:
        return self.detect(station, self.render(T_world_camera), T_world_camera)

    def render(self, T_world_camera: np.ndarray) -> RgbdFrame:
        """The frame the camera sends from ``T_world_camera`` (where it truly is)."""
        rendered = render_rgbd(self._scene(T_world_camera), self.intrinsics, T_world_camera, self.rng,
                               tof=TofEffects())
        self.frames.append(rendered)
        return rendered

    def detect(self, station: int, rendered: RgbdFrame, T_world_camera: np.ndarray) -> list[Detection]:
        """The named detections in ``rendered``, placed from ``T_world_camera``: where the robot believes the
        camera was, which on drifting odometry is not where it was rendered (:mod:`bim2rdt.demo.localized`)."""
        if isinstance(self.detector, IdealDetector):
            self.detector.bind(rendered)
        return self._named(station, replace(rendered, T_world_camera=T_world_camera).as_frame(self.intrinsics))

    def detect_frame(self, station: int, frame: Frame) -> list[Detection]:
        """The robot loop's ``detect`` (:class:`bim2rdt.mission.robot.Detect`): the named detections in
        ``frame``, the frame this camera rendered last, placed where the robot believes it was."""
        if isinstance(self.detector, IdealDetector):
            self.detector.bind(self.frames[-1])  # the renderer's masks of the frame the robot captured last
        return self._named(station, frame)

    def _named(self, station: int, frame: Frame) -> list[Detection]:
        self._latest[station] = frame
        found = locate_detections(frame, self.model, self.detector, station, self.config.perceive)
        named = [d for d in found if d.family != UNKNOWN_FAMILY]
        self.unknown += len(found) - len(named)
        return named

    def station_frame(self, station: int) -> Frame | None:
        """The last frame read for ``station`` (what the robot sent: no labels): the mission's ``frame_of``."""
        return self._latest.get(station)

    def _scene(self, T_world_camera: np.ndarray) -> SiteScene:
        scene = self.reality.scene
        if self.rng.random() >= WORKER_FRACTION:
            return scene
        clear = [o.T_world_model[:3, 3] for o in scene.objects]
        person = worker_in_view(T_world_camera, self.rng, clear, self._footprints)
        return SiteScene(scene.objects, scene.ground_size, scene.building, [person] if person else [])

