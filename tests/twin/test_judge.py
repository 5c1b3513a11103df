"""The one judge verify and the mission share: a trusted fit of that object is judged by its pose; else a place
seen through is missing; else a fit is unverified with why; else the view was not enough (not observed, with why).
The mission's own absence rule (a station's look at a place) gives the same answers through it."""

from __future__ import annotations

import pytest

from bim2rdt.mission import MissionConfig
from bim2rdt.mission.absence import shows_empty
from bim2rdt.perception.visibility import PlaceLook
from bim2rdt.twin import ElementStatus, FitEvidence, JudgeConfig, PlaceEvidence, judge_evidence, place_seen_empty

EMPTY = PlaceEvidence(facing=1000, in_sight=800, through=760, hidden=0)  # 95 % seen through
THERE = PlaceEvidence(facing=1000, in_sight=800, through=80, hidden=0)  # 10 %: something stands there


def test_a_trusted_fit_is_judged_by_its_pose_even_where_its_place_looks_empty():
    """A table seen as a box: the sensor sees under it, yet a fit that explains its points is the table."""
    assert judge_evidence(EMPTY, FitEvidence(0.9), 0.5).status is None


def test_a_place_seen_through_is_missing_when_the_fit_is_not_one_of_that_object():
    landed_elsewhere = FitEvidence(0.9, "(the fit landed on something else)")
    for fit in (None, FitEvidence(0.2), landed_elsewhere):
        verdict = judge_evidence(EMPTY, fit, 0.5)
        assert verdict.status is ElementStatus.MISSING and "95%" in verdict.reason


def test_an_untrusted_fit_at_a_place_not_seen_empty_is_unverified_with_its_reason():
    assert judge_evidence(THERE, FitEvidence(0.2), 0.5).reason == "(the fit explains 20% of its points, under 50%)"
    verdict = judge_evidence(THERE, FitEvidence(0.9, "(on the wall)"), 0.5)
    assert verdict.status is ElementStatus.UNVERIFIED and verdict.reason == "(on the wall)"


@pytest.mark.parametrize("place, words", [
    (PlaceEvidence(facing=1000, in_sight=10, through=10), "not enough"),  # too little in sight
    (PlaceEvidence(facing=1000, in_sight=300, through=290, hidden=700), "hidden behind"),  # mostly hidden
    (PlaceEvidence(facing=1000, in_sight=150, through=140, in_frame=200), "in the image"),  # mostly outside
    (THERE, "too few points of its own"),
    (None, "not looked at"),
])
def test_without_a_fit_a_place_not_shown_empty_is_not_observed_with_why(place, words):
    verdict = judge_evidence(place, None, 0.5)
    assert verdict.status is ElementStatus.NOT_OBSERVED and words in verdict.reason


def test_a_place_is_empty_only_in_view_in_sight_and_not_hidden():
    config = JudgeConfig()
    assert place_seen_empty(EMPTY, config)
    assert not place_seen_empty(PlaceEvidence(1000, 180, 170, 0, in_frame=200), config)  # mostly out of the image
    assert not place_seen_empty(PlaceEvidence(1000, 400, 390, 500), config)  # more hidden than in sight
    assert not place_seen_empty(PlaceEvidence(1000, 20, 20, 0), config)  # under min_place_points
    assert not place_seen_empty(THERE, config)


@pytest.mark.parametrize("look, empty", [
    (PlaceLook(facing=100, in_frame=100, seen=80, through=76, blocked=0), True),
    (PlaceLook(facing=100, in_frame=40, seen=40, through=40, blocked=0), False),  # under missing_in_view
    (PlaceLook(facing=100, in_frame=100, seen=90, through=40, blocked=50), False),  # over half occluded
    (PlaceLook(facing=100, in_frame=100, seen=80, through=50, blocked=0), False),  # 62 % through
    (PlaceLook(facing=100, in_frame=100, seen=20, through=20, blocked=0), False),  # under min_points
])
def test_the_missions_look_at_a_place_is_judged_by_the_same_rule(look, empty):
    assert shows_empty(look, MissionConfig()) is empty
