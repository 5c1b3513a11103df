"""A simulated quadruped with a mast camera: it walks to camera poses, turns in place and captures RGB-D frames,
and reports only what a real one would (frames and drifting odometry). Its true pose stays here, for scoring."""

from __future__ import annotations

import numpy as np

from bim2rdt.localization.planar import from_planar, to_planar
from bim2rdt.localization.station import Turned
from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.frame import Frame
from bim2rdt.sim.odometry import OdometryReading, SimulatedOdometry
from bim2rdt.sim.scene import SiteScene
from bim2rdt.sim.tour import render_frame


class SimulatedRobot:
    """Starts at ``T_world_camera``; ``walk_to`` and ``turn`` move the true pose and return odometry readings,
    ``capture`` renders a noisy frame of ``scene`` from the true pose. Seeded."""

    def __init__(self, scene: SiteScene, T_world_camera: np.ndarray, seed: int = 0,
                 intrinsics: Intrinsics = Intrinsics()):
        self.scene, self.intrinsics = scene, intrinsics
        self.T_world_camera = np.asarray(T_world_camera, dtype=float).copy()
        self.odometry = SimulatedOdometry(seed)
        self.rng = np.random.default_rng(seed)

    def walk_to(self, T_world_camera: np.ndarray) -> OdometryReading:
        """Walk (turn, straight, turn) to a new camera pose; the odometry reading of the leg."""
        start, _ = to_planar(self.T_world_camera)
        goal, _ = to_planar(T_world_camera)
        self.T_world_camera = np.asarray(T_world_camera, dtype=float).copy()
        return self.odometry.leg(np.stack([start, goal]))

    def capture(self) -> Frame:
        return render_frame(self.scene, self.T_world_camera, self.rng, self.intrinsics)

    def turn(self, angle: float) -> Turned:
        """Turn in place by ``angle`` rad about the vertical, capture; the frame and the turn's odometry."""
        state, tilt = to_planar(self.T_world_camera)
        turned = state + np.array([0.0, 0.0, 0.0, angle])
        reading = self.walk_to(from_planar(turned, tilt))
        return Turned(self.capture(), reading.increment, reading.distance, reading.turned)

