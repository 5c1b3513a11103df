"""Pose errors modulo each family's true symmetry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bim2rdt.registration.so3 import axis_angle
from bim2rdt.registration.symmetry import closest_equivalent
from bim2rdt.sim.truth import MESH_SYMMETRY, match_truth, pose_error, true_symmetry


def _turned(yaw: float, tilt: float = 0.0) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = axis_angle(np.array([0.0, 0.0, 1.0]), np.array(yaw)) @ axis_angle(
        np.array([1.0, 0.0, 0.0]), np.array(tilt))
    return T


def test_a_drum_turned_about_its_axis_is_not_an_error():
    error = pose_error("Steel_Drum_55gal", _turned(1.3), np.eye(4))
    assert error.rotation_deg == pytest.approx(0.0, abs=1e-9)
    assert pose_error("Steel_Drum_55gal", _turned(1.3, 0.05), np.eye(4)).rotation_deg == pytest.approx(
        np.rad2deg(0.05), abs=1e-6)


def test_a_pallet_turned_by_half_a_turn_is_not_an_error_but_a_crate_is():
    assert pose_error("Pallet_Wood_EUR", _turned(np.pi), np.eye(4)).rotation_deg == pytest.approx(0.0, abs=1e-6)
    assert pose_error("Wooden_Crate_1200x800x600", _turned(np.pi), np.eye(4)).rotation_deg == pytest.approx(180.0)


def test_the_closest_equivalent_of_a_symmetric_pose_is_the_truth():
    shown = closest_equivalent(_turned(np.pi / 2), np.eye(4), true_symmetry("Traffic_Cone_Orange_70cm"))
    assert np.allclose(shown, np.eye(4), atol=1e-9)


def test_success_needs_both_rotation_and_translation_within_the_bars():
    T = np.eye(4)
    T[0, 3] = 0.02
    assert not pose_error("Wooden_Crate_1200x800x600", T, np.eye(4)).success()
    assert pose_error("Wooden_Crate_1200x800x600", _turned(0.01), np.eye(4)).success()


@pytest.mark.parametrize("pose, mode", [
    (_turned(0.0), "ok"),
    (_turned(0.0, np.deg2rad(5.0)), "tilt"),
    (_turned(np.pi, np.deg2rad(5.0)), "tilt"),
    (_turned(np.pi), "flip"),
    (_turned(np.deg2rad(10.0)), "yaw"),
])
def test_failures_are_classified_by_the_first_bar_they_miss(pose, mode):
    assert pose_error("Wooden_Crate_1200x800x600", pose, np.eye(4)).failure_mode() == mode


def test_a_pose_with_the_right_rotation_but_off_by_two_centimetres_slid():
    T = np.eye(4)
    T[1, 3] = 0.02
    assert pose_error("Wooden_Crate_1200x800x600", T, np.eye(4)).failure_mode() == "slide"


@pytest.mark.parametrize("family", sorted(MESH_SYMMETRY))
def test_each_simulated_shapes_true_symmetry_is_part_of_its_priors(family):
    """Scoring and verdict agree: a turn the truth forgives the prior forgives too (a prior may forgive more:
    the crate prior's half turn, which the simulated crate's cleat breaks, is then a real error)."""
    from bim2rdt.semantics import KnowledgeBasePriors

    true, prior = true_symmetry(family), KnowledgeBasePriors().prior(family).symmetry
    assert prior == math.inf if true == math.inf else (prior == math.inf or prior % true == 0)


def test_a_shape_the_simulator_did_not_build_is_scored_with_its_priors_symmetry():
    assert pose_error("Bucket_20l", _turned(0.7), np.eye(4), prior_symmetry=math.inf).rotation_deg == pytest.approx(
        0.0, abs=1e-9)
    assert pose_error("Bucket_20l", _turned(0.7), np.eye(4)).rotation_deg == pytest.approx(np.rad2deg(0.7))


def _at(x: float, y: float) -> np.ndarray:
    T = np.eye(4)
    T[:2, 3] = (x, y)
    return T


def test_observations_are_matched_to_the_truth_by_family_and_place_one_to_one():
    truth = [("drum", _at(0.0, 0.0)), ("drum", _at(0.9, 0.0)), ("cone", _at(0.05, 0.0))]
    found = [("drum", _at(0.88, 0.01)), ("cone", _at(0.0, 0.0)), ("drum", _at(0.02, 0.0)), ("drum", _at(0.5, 0.0))]
    assert match_truth(found, truth) == [1, 2, 0, None]  # the 4th drum is a phantom: both drums are taken


def test_an_observation_far_from_every_true_object_of_its_family_matches_none():
    assert match_truth([("crate", _at(3.0, 0.0))], [("crate", _at(0.0, 0.0)), ("drum", _at(3.0, 0.0))]) == [None]
