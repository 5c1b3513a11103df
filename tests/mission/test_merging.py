"""Merging views without the truth: the mission sees each object from several stations and must report it once.

The scenes are simulated, but the mission gets nothing of the truth: detections carry a family label, world
points and the station they came from."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.mission import MissionConfig, Target, run_mission
from bim2rdt.perception.camera import look_at
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.reality import Reality, SimulatedPerception, TrueObject
from bim2rdt.sim.scene import PlacedObject, SiteScene, ground_pose

CRATE, DRUM = "Wooden_Crate_1200x800x600", "Steel_Drum_55gal"


def _reality(*objects: tuple[str, float, float, float]) -> Reality:
    truth = [TrueObject(None, family, ground_pose(x, y, yaw), "unplanned") for family, x, y, yaw in objects]
    placed = [PlacedObject(t.family, mesh_for_family(t.family), t.T_world_model, albedo=0.5) for t in truth]
    return Reality(SiteScene(placed, ground_size=30.0), truth)


def _stations(*eyes: tuple[float, float]) -> list[np.ndarray]:
    return [look_at(np.array([x, y, 1.1]), np.array([0.0, 0.0, 0.35])) for x, y in eyes]


def _mission(reality: Reality, stations: list[np.ndarray], targets=()):
    families = sorted({t.family for t in reality.truth})
    return run_mission(list(targets), stations, SimulatedPerception(reality, seed=0),
                       KnowledgeBasePriors().priors(families), mesh_for_family, MissionConfig())


def test_one_object_seen_from_two_stations_without_truth_gives_one_observation():
    reality = _reality((CRATE, 0.0, 0.0, 0.3))
    stations = _stations((2.6, -0.6), (-1.2, -2.4))
    result = _mission(reality, stations)
    assert len(result.observations) == 1
    observation = result.observations[0]
    assert observation.frames == (0, 1)
    assert np.linalg.norm(observation.pose[:2, 3]) < 0.02


def test_a_planned_object_seen_from_two_stations_is_verified_once_and_nothing_is_new():
    reality = _reality((CRATE, 0.0, 0.0, 0.3))
    target = Target("crate-1", CRATE, ground_pose(0.0, 0.0, 0.3), mesh_for_family(CRATE))
    result = _mission(reality, _stations((2.6, -0.6), (-1.2, -2.4), (0.5, 2.6)), [target])
    assert [obs.global_id for obs in result.observations] == ["crate-1"]
    assert result.observations[0].frames == (0, 1, 2) and result.not_seen == []


def test_two_objects_of_one_family_side_by_side_stay_two_observations():
    """Merging must not swallow a neighbour: the second drum's points are not on the first drum's surface."""
    reality = _reality((DRUM, -0.45, 0.0, 0.0), (DRUM, 0.45, 0.0, 0.0))
    result = _mission(reality, _stations((0.0, -2.6), (1.8, -1.8)))
    centres = sorted(obs.pose[0, 3] for obs in result.observations)
    assert centres == pytest.approx([-0.45, 0.45], abs=0.03)
    assert all(obs.frames == (0, 1) for obs in result.observations)


def test_a_fit_with_no_inlier_is_unverified_with_the_reason_and_the_twin_takes_it(monkeypatch, site_model, tmp_path):
    """A partial view behind a wall can leave no point within the inlier radius of the fitted model (the
    registration says rmse inf, fitness 0). The mission calls that unverified and says why; it never stops the
    day, and the twin records it."""
    import dataclasses
    import math

    from bim2rdt.mission import run as mission_run
    from bim2rdt.twin import DigitalTwin, ElementStatus

    real_fit = mission_run.fit_target

    def no_inlier(*args, **kwargs):
        return dataclasses.replace(real_fit(*args, **kwargs), rmse=math.inf, fitness=0.0)

    monkeypatch.setattr(mission_run, "fit_target", no_inlier)
    result = _mission(_reality((CRATE, 0.0, 0.0, 0.3)), _stations((2.6, -0.6)))
    observation = result.observations[0]
    assert observation.status is ElementStatus.UNVERIFIED and observation.reason.startswith("(no inlier")
    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model) as twin:
        assert twin.record(observation, 0.0).status is ElementStatus.UNVERIFIED
