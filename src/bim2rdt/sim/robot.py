"""A simulated quadruped with a mast camera: it walks to camera poses, turns in place and captures RGB-D frames,
and reports only what a real one would (frames and drifting odometry). Its true pose stays here, for scoring."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from bim2rdt.localization.planar import compose, from_planar, to_planar
from bim2rdt.localization.station import Turned
from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.frame import Frame
from bim2rdt.sim.odometry import OdometryReading, SimulatedOdometry
from bim2rdt.sim.scene import SiteScene
from bim2rdt.sim.render import RgbdFrame, render_rgbd


class SimulatedRobot:
    """Starts at ``T_world_camera``; ``walk_to``, ``drive`` and ``turn`` move the true pose and return odometry
    readings, ``render``/``capture`` a noisy frame from the true pose. Seeded. It is a
    :class:`bim2rdt.mission.robot.Robot` (``drive``, ``capture``, ``turn``), so the library's robot loop runs on it."""

    def __init__(self, scene: SiteScene | None, T_world_camera: np.ndarray, seed: int = 0,
                 intrinsics: Intrinsics = Intrinsics(), renderer: Callable[[np.ndarray], RgbdFrame] | None = None):
        self.scene, self.intrinsics, self.renderer = scene, intrinsics, renderer
        self.T_world_camera = np.asarray(T_world_camera, dtype=float).copy()
        self.odometry = SimulatedOdometry(seed)
        self.rng = np.random.default_rng(seed)
        self.captured: list[np.ndarray] = []
        """The true camera pose of every capture, in order: the truth a run is scored against afterwards."""

    def walk_to(self, T_world_camera: np.ndarray) -> OdometryReading:
        """Walk (turn, straight, turn) to a new camera pose; the odometry reading of the leg."""
        start, _ = to_planar(self.T_world_camera)
        goal, _ = to_planar(T_world_camera)
        self.T_world_camera = np.asarray(T_world_camera, dtype=float).copy()
        return self.odometry.leg(np.stack([start, goal]))

    def drive(self, increment: np.ndarray, R_level_camera: np.ndarray) -> OdometryReading:
        """Carry out a commanded move (forward, left, up m, turn rad, in the current heading frame; the camera's
        tilt set to ``R_level_camera``): the true pose moves by exactly that, the odometry reports it with drift."""
        state, _ = to_planar(self.T_world_camera)
        return self.walk_to(from_planar(compose(state, increment), R_level_camera))

    def render(self) -> RgbdFrame:
        """A noisy frame from the true pose, with the simulator's labels: ``renderer``'s when given (a camera
        model with its own artefacts), else a plain ray cast of ``scene``."""
        if self.renderer is not None:
            return self.renderer(self.T_world_camera)
        return render_rgbd(self.scene, self.intrinsics, self.T_world_camera, self.rng)

    def capture(self) -> Frame:
        """What the robot sends: the frame without labels (its true pose is kept in ``captured``)."""
        self.captured.append(self.T_world_camera.copy())
        return self.render().as_frame(self.intrinsics)

    def turn(self, angle: float) -> Turned:
        """Turn in place by ``angle`` rad about the vertical, capture; the frame and the turn's odometry."""
        _, tilt = to_planar(self.T_world_camera)
        reading = self.drive(np.array([0.0, 0.0, 0.0, angle]), tilt)
        return Turned(self.capture(), reading.increment, reading.distance, reading.turned)

