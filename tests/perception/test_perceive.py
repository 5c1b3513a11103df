"""perceive_frame / perceive_frames: the public contract, fusion of views, and bad input."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from bim2rdt.perception import (Detection, Frame, GeometricDetector, Intrinsics, Observation, PerceptionError,
                                look_at, perceive_frame, perceive_frames)
from bim2rdt.sim.truth import pose_error

from tests.perception.conftest import CONE, DRUM, element, placed, render


class Given:
    """A detector that hands back fixed detections (bad ones included)."""

    name = "given"

    def __init__(self, detections):
        self.detections = detections

    def detect(self, frame):
        return self.detections


def test_an_unmoved_cone_is_its_bim_element_at_its_bim_pose(site, priors):
    cone = element(site, CONE, 1)
    frame, _ = render(site, [placed(CONE, *cone.position[:2], 15.0)], look_at((4.2, 4.6, 1.1), (4.2, 2.0, 0.35)))
    [obs] = perceive_frame(frame, site, priors)
    assert isinstance(obs, Observation)
    assert (obs.family, obs.global_id, obs.detector) == (CONE, cone.global_id, "geometric")
    error = pose_error(CONE, obs.pose, cone.placement)
    assert error.translation < 0.01 and error.rotation_deg < 2.0
    assert obs.fitness > 0.9 and 0.0 < obs.rmse < 0.01 and obs.points >= 100 and 0.0 < obs.score <= 1.0
    assert obs.bbox is not None and obs.frames == (0,) and obs.fit is not None


def test_a_moved_drum_keeps_its_element_and_an_unplanned_one_has_none(site, priors):
    drum = element(site, DRUM)
    moved = drum.placement.copy()
    moved[:2, 3] += (0.0, 0.4)
    objects = [placed(DRUM, *moved[:2, 3]), placed(DRUM, 13.2, 3.2)]
    frame, _ = render(site, objects, look_at((11.0, 2.2, 1.1), (14.5, 2.8, 0.4)))
    observations = {obs.global_id: obs for obs in perceive_frame(frame, site, priors)}
    assert set(observations) == {drum.global_id, None}
    assert np.linalg.norm(observations[drum.global_id].pose[:2, 3] - moved[:2, 3]) < 0.02
    assert np.linalg.norm(observations[None].pose[:2, 3] - (13.2, 3.2)) < 0.02


def test_two_views_of_one_object_fuse_into_one_observation(site, priors):
    drum = element(site, DRUM)
    objects = [placed(DRUM, *drum.position[:2])]
    views = [render(site, objects, look_at(eye, (15.5, 2.5, 0.4)), seed=k)[0]
             for k, eye in enumerate([(12.5, 1.5, 1.1), (13.0, 4.5, 1.1)])]
    single = perceive_frame(views[0], site, priors)[0]
    [fused] = perceive_frames(views, site, priors, GeometricDetector(site, priors))
    assert fused.frames == (0, 1) and fused.global_id == drum.global_id
    assert fused.points > single.points


def test_unusable_detections_are_dropped_with_a_one_line_reason(site, priors, caplog):
    frame, _ = render(site, [], look_at((10.0, 3.0, 1.1), (15.0, 9.0, 0.5)))
    sky = np.zeros((480, 640), dtype=bool)
    sky[:5, :5] = True
    bad = [Detection(DRUM, bbox=(700, 10, 800, 60)),  # off the image
           Detection(DRUM, bbox=(0, 0, 5, 5), mask=sky),  # nothing with depth there (sky)
           Detection(DRUM, bbox=(10, 10, 50, 50), mask=np.ones((10, 10), dtype=bool))]  # a mask of another size
    frame = Frame(frame.rgb, np.where(sky, np.nan, frame.depth), frame.intrinsics, frame.T_world_camera)
    with caplog.at_level(logging.WARNING, logger="bim2rdt.perception"):
        assert perceive_frame(frame, site, priors, Given(bad)) == []
    reasons = [r.getMessage() for r in caplog.records]
    assert any("lies off the 640x480 image" in r for r in reasons)
    assert any("valid depth" in r for r in reasons)
    assert any("mask of shape (10, 10)" in r for r in reasons)
    assert all("\n" not in r for r in reasons)


def test_a_label_only_detection_is_mapped_to_the_family_its_prompt_names(site, priors):
    """A detector that knows only its prompts (YOLOE without families) still gets a BIM family."""
    drum = element(site, DRUM)
    frame, rendered = render(site, [placed(DRUM, *drum.position[:2])], look_at((12.5, 1.5, 1.1), (15.5, 2.5, 0.4)))
    mask = rendered.labels == 0
    vs, us = np.nonzero(mask)
    prompt = "a steel drum on a construction site"
    detection = Detection(prompt, label=prompt, bbox=(us.min(), vs.min(), us.max() + 1, vs.max() + 1), mask=mask)
    [obs] = perceive_frame(frame, site, priors, Given([detection]))
    assert obs.family == DRUM and obs.global_id == drum.global_id


def test_frames_with_bad_shapes_units_or_poses_are_refused_in_one_line():
    rgb, depth = np.zeros((480, 640, 3), np.uint8), np.full((480, 640), 2.0, np.float32)
    with pytest.raises(PerceptionError, match="depth has shape"):
        Frame(rgb, depth[:, :600], Intrinsics(), np.eye(4))
    with pytest.raises(PerceptionError, match="millimetres"):
        Frame(rgb, depth * 1000.0, Intrinsics(), np.eye(4))
    pose = np.eye(4)
    pose[0, 3] = np.nan
    with pytest.raises(PerceptionError, match="finite 4x4"):
        Frame(rgb, depth, Intrinsics(), pose)
    with pytest.raises(PerceptionError, match="expected a Frame"):
        perceive_frames([rgb], None, {})
