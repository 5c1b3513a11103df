"""The robot loop runs on any robot: here a stand-in written in the test (no simulator class), that moves exactly
as told and captures blank frames without a pose, and a detector stand-in that sees one drum. The loop drives it to the station,
places the frame with its own estimate (never the frame's own pose), and the mission judges the drum."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bim2rdt.localization import Turned
from bim2rdt.localization.planar import compose, from_planar, to_planar
from bim2rdt.mission import MissionConfig, MissionContext, Target, dock_pose, run_robot_mission
from bim2rdt.perception import Detection, Frame, Intrinsics, look_at
from bim2rdt.registration import sample_model
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.scene import ground_pose
from bim2rdt.twin import ElementStatus

DRUM = "Steel_Drum_55gal"
INTRINSICS = Intrinsics(width=64, height=48, fx=52.5, fy=52.5, cx=31.5, cy=23.5)


@dataclass
class Reading:
    increment: np.ndarray
    distance: float
    turned: float


@dataclass
class ExactRobot:
    """Moves exactly as commanded; its frames carry no depth and no pose, as a sensor that does not know where it
    is would send them (a time stamp only)."""

    T_world_camera: np.ndarray
    captures: list[np.ndarray] = field(default_factory=list)

    def drive(self, increment: np.ndarray, R_level_camera: np.ndarray) -> Reading:
        state, _ = to_planar(self.T_world_camera)
        self.T_world_camera = from_planar(compose(state, increment), R_level_camera)
        return Reading(np.asarray(increment, float), float(np.hypot(*increment[:2])), abs(float(increment[3])))

    def capture(self) -> Frame:
        self.captures.append(self.T_world_camera.copy())
        return Frame(np.zeros((48, 64, 3), np.uint8), np.full((48, 64), np.nan, np.float32), INTRINSICS,
                     time=float(len(self.captures)))

    def turn(self, angle: float) -> Turned:
        _, tilt = to_planar(self.T_world_camera)
        reading = self.drive(np.array([0.0, 0.0, 0.0, angle]), tilt)
        return Turned(self.capture(), reading.increment, reading.distance, reading.turned)


@dataclass
class DrumEyes:
    """Sees the drum at ``T_world_drum`` from where ``robot`` truly is; places its points with the frame's pose."""

    robot: ExactRobot
    T_world_drum: np.ndarray
    frames: list[Frame] = field(default_factory=list)

    def __call__(self, station: int, frame: Frame) -> list[Detection]:
        self.frames.append(frame)
        body, _ = sample_model(mesh_for_family(DRUM), 400, seed=1)
        world = body @ self.T_world_drum[:3, :3].T + self.T_world_drum[:3, 3]
        T_camera_world = np.linalg.inv(self.robot.T_world_camera)
        in_camera = world @ T_camera_world[:3, :3].T + T_camera_world[:3, 3]
        placed = in_camera @ frame.T_world_camera[:3, :3].T + frame.T_world_camera[:3, 3]
        return [Detection(DRUM, points_world=placed, station=station)]


def _run():
    drum = ground_pose(0.0, 0.0, 0.0)
    station = look_at(np.array([2.6, 0.0, 1.1]), np.array([0.0, 0.0, 0.35]))
    context = MissionContext([Target("drum-1", DRUM, drum, mesh_for_family(DRUM))], [station], model=None,
                             priors=KnowledgeBasePriors().priors([DRUM]), new_object_mesh=mesh_for_family,
                             config=MissionConfig(), building=())
    dock = dock_pose([station], (1.0, 2.0), MissionConfig().camera_height)
    robot = ExactRobot(dock)
    eyes = DrumEyes(robot, drum)
    return run_robot_mission(context, robot, eyes, dock, anchored=False), robot, eyes, station


def test_the_loop_drives_any_robot_to_its_station_and_places_frames_with_its_own_estimate():
    run, robot, eyes, station = _run()
    assert np.allclose(robot.T_world_camera, station, atol=1e-9)  # walked there on its odometry
    assert len(eyes.frames) == len(robot.captures) == 1
    assert eyes.frames[0].has_pose and np.allclose(eyes.frames[0].T_world_camera, station, atol=1e-9)
    assert eyes.frames[0].time == 1.0  # the captured frame itself, placed by the loop's estimate
    located = run.stations[0]
    assert located.capture == 0 and np.allclose(located.estimate, station, atol=1e-9) and located.looks == []


def test_the_mission_judges_what_a_non_simulated_robot_saw():
    run, _, _, _ = _run()
    (observation,) = run.result.observations
    assert observation.global_id == "drum-1" and observation.status is ElementStatus.AS_PLANNED
    assert np.linalg.norm(observation.pose[:3, 3]) < 0.01
    assert run.result.missing == [] and run.result.not_seen == []
