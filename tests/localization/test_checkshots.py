"""Check shots: landmarks an engineer can tape (column corners, wall ends, room corners) measured from a fix."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.localization.checkshots import check_shots, landmarks
from bim2rdt.perception import look_at
from loc_helpers import frame, offset

COLUMNS_VIEW = look_at((8.5, 2.0, 1.1), (11.85, 6.5, 0.8))
"""Columns C12 and C13, C22 far off, and the interior wall's south end."""


def _named(shots):
    return {shot.landmark.name: shot for shot in shots}


def test_the_embedded_sites_landmarks_are_its_column_corners_wall_ends_and_room_corners(site_model):
    marks = {(m.kind, round(float(m.xy[0]), 2), round(float(m.xy[1]), 2)) for m in landmarks(site_model)}
    columns = {(x, y) for kind, x, y in marks if kind == "column corner"}
    assert len(columns) == 24 and (5.8, 4.8) in columns and (14.2, 10.2) in columns
    assert ("inside corner", 0.3, 0.3) in marks and ("inside corner", 19.7, 6.0) in marks
    assert ("wall edge", 11.85, 6.0) in marks  # the interior wall's free end


def test_from_the_true_pose_every_landmark_in_sight_sits_where_the_bim_says(site_model, built):
    check = check_shots(frame(built, COLUMNS_VIEW), site_model, COLUMNS_VIEW)
    shots = _named(check.shots)
    assert "Column C12 column corner at (9.80, 4.80)" in shots
    assert "Interior Wall - North/South wall edge at (11.85, 6.00)" in shots
    assert all(shot.residual < 0.005 for shot in check.shots)
    assert check.residual < 0.005 and not check.flagged
    corner = shots["Column C12 column corner at (9.80, 4.80)"]
    assert corner.tape == pytest.approx(np.hypot(9.8 - 8.5, 4.8 - 2.0))


def test_a_fix_four_centimetres_off_is_flagged_and_measured_at_every_landmark(site_model, built):
    seen = frame(built, COLUMNS_VIEW)
    check = check_shots(seen, site_model, offset(COLUMNS_VIEW, 0.03, -0.03))
    assert len(check.shots) >= 3 and check.flagged
    for shot in check.shots:
        assert shot.residual == pytest.approx(np.hypot(0.03, 0.03), abs=0.004)
        assert shot.shift == pytest.approx([0.03, -0.03], abs=0.004)  # seen where the wrong pose puts it


def test_a_corner_buried_in_the_wall_it_meets_is_never_a_check_shot(site_model, built):
    """The east/west interior wall's west end at (12, 6) is inside the north/south wall: no camera sees it."""
    view = look_at((10.5, 3.0, 1.1), (12.0, 6.0, 1.0))
    check = check_shots(frame(built, view), site_model, view)
    assert all(not (shot.landmark.xy == pytest.approx([12.0, 6.0])) for shot in check.shots)
    assert any(shot.landmark.xy == pytest.approx([11.85, 6.0]) for shot in check.shots)


def test_a_view_without_landmarks_gives_no_residual_and_no_flag(site_model, bare):
    wall = look_at((16.0, 3.0, 1.1), (16.0, 6.0, 0.8))
    check = check_shots(frame(bare, wall), site_model, wall)
    assert check.shots == [] and np.isnan(check.residual) and not check.flagged
