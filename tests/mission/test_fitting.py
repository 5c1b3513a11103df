"""One path from a detection to a fit: the mission (``mission.fitting.fit_target``) and perception's front end
(``perception.perceive``) decide slab contact, starts and the BIM pose's near-tie the same way, because both call
``perception.fitting.fit_detection``.

The registration itself is replaced by a stand-in that records how it was called (start, support height, number
of restarts) and scores each start as the test says, so the decisions are seen directly."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bim2rdt.mission import MissionConfig, Target
from bim2rdt.mission.fitting import fit_target
from bim2rdt.perception import Detection, Intrinsics
from bim2rdt.perception import fitting
from bim2rdt.perception import perceive
from bim2rdt.perception.visibility import DepthView
from bim2rdt.registration import IcpConfig, sample_model
from bim2rdt.semantics import UprightPrior
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.scene import ground_pose

DRUM = "Steel_Drum_55gal"
SLAB = 0.25
PRIOR = UprightPrior(label="steel drum", upright_bias=0.9, yaw_only=True, source="test", rationale="test")


class _Register:
    """Stands in for SG-ICP: each call's start, support height and restarts are kept; the fit stays at its start
    and scores ``local`` when it is the one-restart refinement of the BIM pose, 2 when it is the BIM pose searched
    (restarts), ``searched`` otherwise."""

    def __init__(self, bim_pose: np.ndarray | None, local: float, searched: float = 1.0):
        self.bim_pose, self.local, self.searched, self.calls = bim_pose, local, searched, []

    def __call__(self, model_pts, model_normals, points, *, init, config, support_height, **kwargs):
        self.calls.append(SimpleNamespace(init=init, support=support_height, restarts=config.restarts))
        at_bim = self.bim_pose is not None and np.array_equal(init, self.bim_pose)
        score = (self.local if config.restarts == 1 else 2.0) if at_bim else self.searched
        return SimpleNamespace(pose=init, score=score, rmse=0.01, fitness=0.9)


def _drum(z: float = SLAB, x: float = 3.0) -> np.ndarray:
    T = ground_pose(x, 1.0, 10.0)
    T[2, 3] = z
    return T


def _points(T: np.ndarray) -> np.ndarray:
    vertices = np.asarray(mesh_for_family(DRUM).vertices)
    return vertices @ T[:3, :3].T + T[:3, 3]


def _mission(bim_pose: np.ndarray | None, detector_pose: np.ndarray | None, points: np.ndarray):
    target = Target("drum-1", DRUM, bim_pose, mesh_for_family(DRUM)) if bim_pose is not None else None
    detection = Detection(DRUM, points_world=points, station=0, pose=detector_pose)
    model_pts = np.asarray(mesh_for_family(DRUM).vertices)
    config = MissionConfig(slab_height=SLAB)
    return fit_target(detection, target, model_pts, model_pts * 0, points, PRIOR, config, IcpConfig())


def _perception(bim_pose: np.ndarray | None, detector_pose: np.ndarray | None, points: np.ndarray):
    model_pts = np.asarray(mesh_for_family(DRUM).vertices)
    element = SimpleNamespace(family=DRUM, global_id="drum-1", placement=bim_pose)
    library = SimpleNamespace(families={DRUM: SimpleNamespace(samples=lambda count, seed: (model_pts, model_pts * 0))},
                              near=lambda xy, radius: [element] if bim_pose is not None else [])
    intrinsics = Intrinsics(width=8, height=6, fx=5.0, fy=5.0, cx=4.0, cy=3.0)
    view = DepthView(np.full((6, 8), np.nan, np.float32), intrinsics, np.eye(4))
    seen = perceive._Seen(Detection(DRUM, points_world=points, pose=detector_pose), 0, points, view)
    return perceive._observe([seen], library, {DRUM: PRIOR}, set(), SLAB, perceive.PerceiveConfig()).fit


CALLERS = {"mission": _mission, "perception": _perception}


@pytest.mark.parametrize("caller", CALLERS)
@pytest.mark.parametrize("lift, resting", [(0.0, True), (0.03, True), (0.3, False)])
def test_a_bim_pose_on_the_slab_rests_on_it_and_one_on_a_trestle_does_not_whoever_calls(monkeypatch, caller, lift,
                                                                                         resting):
    bim = _drum(SLAB + lift)
    stand_in = _Register(bim, local=1.0)
    monkeypatch.setattr(fitting, "register", stand_in)
    CALLERS[caller](bim, None, _points(bim))
    assert stand_in.calls and all(call.support == (SLAB if resting else None) for call in stand_in.calls)


@pytest.mark.parametrize("caller", CALLERS)
def test_an_object_the_bim_lacks_rests_where_the_detector_put_it_or_else_on_the_slab(monkeypatch, caller):
    raised = _drum(SLAB + 0.4)
    stand_in = _Register(None, local=1.0)
    monkeypatch.setattr(fitting, "register", stand_in)
    CALLERS[caller](None, raised, _points(raised))
    assert {call.support for call in stand_in.calls} == {None}
    stand_in.calls.clear()
    CALLERS[caller](None, None, _points(_drum()))
    assert {call.support for call in stand_in.calls} == {SLAB}


@pytest.mark.parametrize("caller", CALLERS)
@pytest.mark.parametrize("local, bim_wins", [(1.10, True), (1.15, True), (1.20, False)])
def test_the_bim_pose_wins_a_near_tie_within_the_tie_ratio_whoever_calls(monkeypatch, caller, local, bim_wins):
    """Every start scores 1.0 except the BIM pose refined without restarts: within 1.15 of the best it is kept."""
    bim = _drum()
    moved = _drum(x=3.4)
    stand_in = _Register(bim, local=local)
    monkeypatch.setattr(fitting, "register", stand_in)
    fit = CALLERS[caller](bim, None, _points(moved))
    assert np.array_equal(fit.pose, bim) is bim_wins


def test_both_callers_start_from_the_same_poses_when_neither_trusts_a_detector_search(monkeypatch):
    """Without a detector pose both callers search from the BIM pose, the BIM pose slid onto the points above the
    slab, and nothing else for a drum (not slender); with one, the mission searches from it too while perception
    refines the detector's search (FitRules.refine_detector_pose)."""
    bim, moved = _drum(), _drum(x=3.4)
    starts = {}
    for caller, run in CALLERS.items():
        stand_in = _Register(bim, local=5.0)
        monkeypatch.setattr(fitting, "register", stand_in)
        run(bim, None, _points(moved))
        starts[caller] = [(call.init.round(9).tolist(), call.restarts) for call in stand_in.calls]
    assert starts["mission"] == starts["perception"] and len(starts["mission"]) == 3
    slid = np.array(starts["mission"][1][0])
    assert slid[0][3] == pytest.approx(3.4, abs=0.02)  # centred on the points, at the BIM's yaw and height
    for caller, run in CALLERS.items():
        stand_in = _Register(bim, local=5.0)
        monkeypatch.setattr(fitting, "register", stand_in)
        run(bim, moved, _points(moved))
        restarts = [call.restarts for call in stand_in.calls]
        assert (max(restarts) == 1) is (caller == "perception")


def test_a_slender_objects_start_is_also_shifted_along_its_long_axis_by_what_the_view_misses():
    """A beam 3 m long seen over 1 m: starts 1 m either way along it (the seen part at one end)."""
    beam, _ = sample_model(mesh_for_family("Steel_I-Beam_W12x26_A992"), 2000, seed=0)
    axis = int(np.argmax(np.ptp(beam[:, :2], axis=0)))
    seen = beam[np.abs(beam[:, axis] - beam[:, axis].mean()) < 0.5]
    starts = fitting.along_long_axis(np.eye(4), beam, seen)
    assert len(starts) == 3
    assert sorted(T[axis, 3] for T in starts) == pytest.approx([-1.0, 0.0, 1.0], abs=0.02)
    drum = np.asarray(mesh_for_family(DRUM).vertices)
    assert len(fitting.along_long_axis(np.eye(4), drum, drum)) == 1
