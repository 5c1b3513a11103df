"""A candidate as localization.json lists it says how it was judged: its screen at the coarse pose and whether it
was left unfixed for the fixes' budget (such a place still counts when it might tie)."""

from __future__ import annotations

import json

import numpy as np

from bim2rdt.localization import Candidate


def test_a_candidate_left_unfixed_says_so_with_its_screen_score():
    unfixed = Candidate(np.eye(4), 0.81, None, [], False, 0.7, "Level 0", "imu",
                        reason="not fixed: the search fixes at most 6 places",
                        extra={"screen_score": 0.81, "unchecked": True})
    listed = json.loads(json.dumps(unfixed.to_json()))
    assert listed["unchecked"] is True and listed["screen_score"] == 0.81 and listed["refined"] is False
    fixed = Candidate(np.eye(4), 0.95, np.eye(6), [], True, 0.8, "Level 0", "imu", extra={"screen_score": 0.9})
    assert fixed.to_json()["unchecked"] is False and fixed.to_json()["screen_score"] == 0.9
