"""Scoring perception against the simulated truth: what counts as found, false, a worker, a wrong family."""

from __future__ import annotations

import numpy as np

from bim2rdt.bench.perception.scoring import score_frame, yaw_error_deg
from bim2rdt.perception import UNKNOWN_FAMILY, Detection, Observation
from bim2rdt.sim.reality import TrueObject
from bim2rdt.sim.scene import GROUND, WORKER

CONE, DRUM = "Traffic_Cone_Orange_70cm", "Steel_Drum_55gal"


def _pose(x: float, yaw_deg: float = 0.0) -> np.ndarray:
    c, s = np.cos(np.deg2rad(yaw_deg)), np.sin(np.deg2rad(yaw_deg))
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[0, 3] = x
    return T


def _labels() -> np.ndarray:
    labels = np.full((40, 60), GROUND)
    labels[5:15, 5:15] = 0  # cone, fully visible
    labels[5:15, 20:30] = 1  # drum, barely visible
    labels[20:35, 40:50] = WORKER
    return labels


def _detection(box, family):
    mask = np.zeros((40, 60), dtype=bool)
    mask[box[1]:box[3], box[0]:box[2]] = True
    return Detection(family, bbox=box, mask=mask)


def _observation(box, family, pose):
    return Observation(family, None, pose, 0.005, 0.9, 100, bbox=box)


def test_found_false_worker_and_family_are_counted_as_the_docs_say():
    truth = [TrueObject("a", CONE, _pose(0.0), "unchanged"), TrueObject("b", DRUM, _pose(1.0), "moved")]
    visible = {0: 1.0, 1: 0.1}
    boxes = {"cone": (5, 5, 15, 15), "cone again": (6, 6, 14, 14), "drum": (20, 5, 30, 15),
             "worker": (40, 20, 50, 35), "floor": (50, 0, 60, 5)}
    detections = [_detection(boxes["cone"], CONE), _detection(boxes["cone again"], CONE),
                  _detection(boxes["drum"], DRUM), _detection(boxes["worker"], UNKNOWN_FAMILY),
                  _detection(boxes["floor"], DRUM)]
    observations = [_observation(boxes["cone"], CONE, _pose(0.004, 90.0 + 1.0)),  # square base: 90 deg is no error
                    _observation(boxes["cone again"], CONE, _pose(0.0)),  # the same cone twice: a false positive
                    _observation(boxes["drum"], DRUM, _pose(1.0)),  # 10 % visible: neither way
                    _observation(boxes["worker"], UNKNOWN_FAMILY, _pose(2.0)),  # right: a worker is unknown
                    _observation(boxes["floor"], DRUM, _pose(3.0))]  # nothing there: a false positive
    tally = score_frame(observations, detections, _labels(), truth, visible)
    assert (tally.required, tally.found, tally.true_positives, tally.false_positives) == (1, 1, 1, 2)
    assert (tally.workers_seen, tally.workers_unknown, tally.right_family) == (1, 1, 1)
    assert np.isclose(tally.translation_m[0], 0.004) and np.isclose(tally.yaw_deg[0], 1.0)


def test_a_worker_given_a_family_is_a_false_positive_and_a_wrong_family_a_confusion():
    truth = [TrueObject("a", CONE, _pose(0.0), "unchanged"), TrueObject("b", DRUM, _pose(1.0), "moved")]
    detections = [_detection((40, 20, 50, 35), DRUM), _detection((5, 5, 15, 15), DRUM)]
    observations = [_observation((40, 20, 50, 35), DRUM, _pose(2.0)), _observation((5, 5, 15, 15), DRUM, _pose(0.0))]
    tally = score_frame(observations, detections, _labels(), truth, {0: 1.0, 1: 1.0})
    assert tally.false_positives == 1 and tally.workers_unknown == 0
    assert tally.true_positives == 1 and tally.right_family == 0 and tally.confusions == {f"{CONE} -> {DRUM}": 1}
    assert tally.required == 2 and tally.found == 1


def test_yaw_error_is_taken_modulo_the_familys_symmetry():
    assert np.isclose(yaw_error_deg(CONE, _pose(0.0, 93.0), _pose(0.0)), 3.0)
    assert np.isclose(yaw_error_deg(DRUM, _pose(0.0, 137.0), _pose(0.0)), 0.0, atol=1e-9)
    assert np.isclose(yaw_error_deg("Wooden_Crate_1200x800x600", _pose(0.0, 170.0), _pose(0.0)), 170.0)
