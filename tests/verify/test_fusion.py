"""Evidence from every frame, on made-up looks: positions combined by information (a frame whose fix leaves x
free weighs nothing along x), an outlier frame left out, a free direction that no frame pins makes the element
unverified with that direction, odometry pins what a view leaves free, and a frame's places summed when no fit
is trusted. Transient clusters: a person's shape, and a thing another frame saw through."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.perception.observation import Observation
from bim2rdt.twin import ElementStatus, FitEvidence, Judgement, PlaceEvidence
from bim2rdt.verify.fusion import (ElementLook, FusionConfig, fuse_element, horizontal_sigma, located_covariance,
                                   merge_new)
from bim2rdt.verify.new_objects import NewCluster
from bim2rdt.verify.rays import RangeLookup
from bim2rdt.verify.transient import person_shaped, transient_reason

PLACE = PlaceEvidence(facing=500, in_sight=300, through=20)


def _pose(x: float, y: float) -> np.ndarray:
    T = np.eye(4)
    T[:2, 3] = (x, y)
    return T


def _look(frame: int, x: float, y: float, fitness: float = 0.9, place=PLACE) -> ElementLook:
    observation = Observation("crate", "G", _pose(x, y), 0.01, fitness, 200, frames=(frame,))
    status = None if fitness >= 0.5 else ElementStatus.UNVERIFIED
    return ElementLook("G", frame, place, FitEvidence(fitness), observation, Judgement(status))


def _fix(sigma_x: float, sigma_y: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    camera = _pose(0.0, -3.0)
    return camera, np.diag([sigma_x**2, sigma_y**2, 1e-4, 1e-6, 1e-6, 1e-6])


def test_a_frame_whose_fix_leaves_x_free_weighs_nothing_along_x_but_counts_along_y():
    looks = [_look(0, 1.00, 2.00), _look(1, 1.60, 2.04)]
    fused = fuse_element(looks, {0: _fix(0.01), 1: _fix(60.0)}, 0.5)
    assert fused.status is None and fused.frames == (0, 1)
    x, y = fused.observation.pose[:2, 3]
    assert x == pytest.approx(1.0, abs=1e-3)  # frame 1's x is anything
    assert y == pytest.approx(2.02, abs=2e-3)  # both frames pin y equally
    assert fused.observation.frames == (0, 1)


def test_a_frame_far_from_the_others_is_left_out():
    looks = [_look(0, 1.0, 2.0), _look(1, 1.01, 2.0), _look(2, 0.99, 2.01), _look(3, 1.5, 2.0)]
    fused = fuse_element(looks, {k: _fix(0.01) for k in range(4)}, 0.5)
    assert fused.observation.pose[0, 3] == pytest.approx(1.0, abs=0.01)
    assert fused.observation.frames == (0, 1, 2)


def test_a_direction_no_frame_pins_leaves_the_element_unverified_along_it():
    fused = fuse_element([_look(0, 1.0, 2.0), _look(1, 1.1, 2.0)], {0: _fix(50.0), 1: _fix(80.0)}, 0.5)
    assert fused.status is ElementStatus.UNVERIFIED and "along x" in fused.reason
    assert fused.observation.status is ElementStatus.UNVERIFIED and fused.sigma > 10


def test_odometry_from_a_full_fix_pins_what_the_next_view_leaves_free():
    own_0, own_1 = _pose(0.0, 0.0), _pose(0.5, 0.0)  # the recording moved 50 cm
    free = np.diag([100.0**2, 0.01**2, 1e-4, 1e-6, 1e-6, 1e-6])
    anchor_covariance = np.diag([1e-4] * 3 + [1e-6] * 3)
    located = located_covariance(free, (own_0, _pose(3.0, 4.0)), anchor_covariance, own_1, FusionConfig())
    assert horizontal_sigma(free) > 50 and horizontal_sigma(located) == pytest.approx(0.045, abs=0.005)
    assert located_covariance(free, (None, _pose(3.0, 4.0)), None, own_1) is free  # the user's prior: nothing


def test_without_a_trusted_fit_the_frames_places_are_summed_and_judged_once():
    half = PlaceEvidence(facing=30, in_sight=20, through=20)  # each frame alone: too little in sight
    looks = [ElementLook("G", k, half, None, None, Judgement(ElementStatus.NOT_OBSERVED)) for k in range(2)]
    fused = fuse_element(looks, {0: _fix(0.01), 1: _fix(0.01)}, 0.5)
    assert fused.status is ElementStatus.MISSING and fused.frames == (0, 1)
    alone = fuse_element(looks[:1], {0: _fix(0.01)}, 0.5)
    assert alone.status is ElementStatus.NOT_OBSERVED and "not enough" in alone.reason
    untrusted = fuse_element([_look(0, 1.0, 2.0, fitness=0.2)], {0: _fix(0.01)}, 0.5)
    assert untrusted.status is ElementStatus.UNVERIFIED and "20%" in untrusted.reason
    assert fuse_element([_look(0, 1.0, 2.0, 0.2)], {0: _fix(50.0)}, 0.5).status is ElementStatus.NOT_OBSERVED


def _cluster(frame: int, low, high, points: int = 300) -> NewCluster:
    low, high = np.asarray(low, float), np.asarray(high, float)
    pose = _pose((low[0] + high[0]) / 2, (low[1] + high[1]) / 2)
    grid = np.stack(np.meshgrid(*[np.linspace(a, b, 7) for a, b in zip(low, high)]), axis=-1).reshape(-1, 3)
    return NewCluster(Observation("unknown", None, pose, 0.0, 1.0, points, frames=(frame,)), grid, low, high, 0.0,
                      frames=(frame,))


def test_clusters_of_several_frames_are_one_object_but_two_of_one_frame_stay_two():
    a0, b0 = _cluster(0, (0, 0, 0), (0.4, 0.4, 0.8)), _cluster(0, (0.45, 0, 0), (0.85, 0.4, 0.8), 200)
    a1 = _cluster(1, (0.05, 0, 0), (0.45, 0.4, 0.8))
    merged = merge_new([a0, b0, a1])
    assert len(merged) == 2 and merged[0].frames == (0, 1) and merged[1].frames == (0,)


def test_a_person_shaped_cluster_is_transient_and_a_chair_or_a_shelf_is_not():
    assert person_shaped(_cluster(0, (2.0, 1.0, 0.02), (2.5, 1.3, 1.75)))
    assert "person" in transient_reason(_cluster(0, (2.0, 1.0, 0.02), (2.5, 1.3, 1.75)), [])
    assert not person_shaped(_cluster(0, (2.0, 1.0, 0.02), (2.5, 1.5, 1.05)))  # an office chair
    assert not person_shaped(_cluster(0, (2.0, 1.0, 0.02), (3.8, 1.4, 1.9)))  # a shelf: too wide
    assert not person_shaped(_cluster(0, (2.0, 1.0, 1.2), (2.4, 1.3, 2.9)))  # boxes on a wardrobe


def test_a_cluster_another_frame_saw_through_moved():
    barrow = _cluster(0, (2.0, 1.0, 0.02), (2.6, 1.8, 0.9))
    camera = np.eye(4)
    camera[:3, 3] = (2.3, -2.0, 1.0)
    rays = barrow.sample - camera[:3, 3]
    beyond = rays * 3.0  # the wall behind: the other frame saw past where the barrow stood
    assert "moved" in transient_reason(barrow, [RangeLookup.of(beyond, camera)])
    on_it = rays * 1.0  # the other frame saw it where it was
    assert transient_reason(barrow, [RangeLookup.of(on_it, camera)]) == ""
