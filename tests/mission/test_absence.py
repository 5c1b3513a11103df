"""Missing without an oracle: a planned element is missing only when a station's frame shows its place empty
(the camera saw through it). Not looked at, or occluded, or there but not detected: not missing.

The frames are simulated; the mission gets detections and the frames' depth, never the truth."""

from __future__ import annotations

import numpy as np
import trimesh

from bim2rdt.mission import MissionConfig, Target, run_mission
from bim2rdt.perception.camera import look_at
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.reality import Reality, SimulatedPerception, TrueObject
from bim2rdt.sim.scene import PlacedObject, SiteScene, ground_pose

DRUM = "Steel_Drum_55gal"
EYE = look_at(np.array([2.6, 0.0, 1.1]), np.array([0.0, 0.0, 0.35]))
AWAY = look_at(np.array([2.6, 0.0, 1.1]), np.array([6.0, 0.0, 0.35]))


class _Camera(SimulatedPerception):
    """The simulated camera with a detector that finds nothing: the absence test must rest on depth alone."""

    def __call__(self, station, T_world_camera):
        super().__call__(station, T_world_camera)
        return []


def _wall(y: float = 0.0, width: float = 3.0) -> PlacedObject:
    box = trimesh.creation.box(extents=(0.2, width, 2.4), transform=trimesh.transformations.translation_matrix((0, 0, 1.2)))
    return PlacedObject("wall", box, ground_pose(1.3, y, 0.0), albedo=0.5)


def _mission(objects: list[PlacedObject], stations: list[np.ndarray], detect: bool = False):
    drum = Target("drum-1", DRUM, ground_pose(0.0, 0.0, 0.0), mesh_for_family(DRUM))
    reality = Reality(SiteScene(objects, ground_size=30.0), [TrueObject(None, o.family, o.T_world_model, "unplanned")
                                                             for o in objects])
    camera = (SimulatedPerception if detect else _Camera)(reality, seed=0)
    return run_mission([drum], stations, camera, KnowledgeBasePriors().priors([DRUM]), mesh_for_family,
                       MissionConfig(), frame_of=camera.station_frame)


def _drum_at(x: float) -> PlacedObject:
    return PlacedObject(DRUM, mesh_for_family(DRUM), ground_pose(x, 0.0, 0.0), albedo=0.5)


def test_a_planned_object_whose_place_the_camera_saw_through_is_missing_with_evidence():
    result = _mission([], [AWAY, EYE])
    assert [m.global_id for m in result.missing] == ["drum-1"] and result.not_seen == []
    gone = result.missing[0]
    assert gone.station == 1 and gone.frames == (1,) and gone.see_through >= 0.8 and gone.cells >= 30


def test_an_object_whose_place_is_behind_a_wall_is_not_missing_but_not_seen():
    result = _mission([_wall()], [EYE])
    assert result.missing == [] and result.not_seen == ["drum-1"]


def test_a_place_partly_behind_a_post_is_judged_on_the_part_the_camera_sees():
    """A post hides nearly half of the place; the rest is seen through: missing (occluded cells are no evidence
    either way, but the open ones are)."""
    result = _mission([_wall(y=0.08, width=0.12)], [EYE])
    assert [m.global_id for m in result.missing] == ["drum-1"]


def test_an_object_never_looked_at_is_not_seen_not_missing():
    result = _mission([], [AWAY])
    assert result.missing == [] and result.not_seen == ["drum-1"]


def test_an_object_standing_there_undetected_is_not_missing():
    """The detector missed it, but the depth shows a surface where it should be: no evidence of absence."""
    result = _mission([_drum_at(0.0)], [EYE])
    assert result.missing == [] and result.not_seen == ["drum-1"]


def test_a_detected_object_is_observed_and_a_moved_one_leaves_no_missing_behind():
    result = _mission([_drum_at(0.5)], [EYE], detect=True)
    assert [o.global_id for o in result.observations] == ["drum-1"] and result.missing == []


def test_a_fit_standing_where_the_camera_saw_through_is_set_aside_or_unverified(monkeypatch):
    """The free-space test in the mission's fitting: among the fits from every start the plausible one wins
    even at a worse score; when every start ends where the station's depth shows free space (a drum pulled
    half a metre towards the camera, the mirror side of an arc), the verdict is unverified, with the reason."""
    import dataclasses
    from types import SimpleNamespace

    from bim2rdt.mission import run as mission_run
    from bim2rdt.perception import fitting
    from bim2rdt.twin import ElementStatus

    starts = [np.eye(4), np.eye(4) * 2]
    monkeypatch.setattr(fitting, "register", lambda *a, init, **k: SimpleNamespace(pose=init, score=float(init[0, 0])))
    pick = fitting.fit_detection(np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)), None, starts,
                                 SimpleNamespace(upright_bias=0.5, yaw_only=False), 0.0,
                                 fitting.FitRules(refine_detector_pose=True), plausible=lambda fit: fit.score > 1.5)
    assert pick.pose is starts[1]
    monkeypatch.undo()

    real_fit = mission_run.fit_target

    def towards_camera(*args, **kwargs):
        fit = real_fit(*args, **kwargs)
        pose = fit.pose.copy()
        pose[0, 3] += 0.5  # the camera stands at +x
        return dataclasses.replace(fit, pose=pose)

    monkeypatch.setattr(mission_run, "fit_target", towards_camera)
    result = _mission([_drum_at(0.0)], [EYE], detect=True)
    observation = result.observations[0]
    assert observation.status is ElementStatus.UNVERIFIED and "saw through" in observation.reason
