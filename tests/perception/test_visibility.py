"""Free-space consistency: the true pose stands where the camera saw the object; a mirror solution does not."""

from __future__ import annotations

import numpy as np

from bim2rdt.perception import PerceiveConfig, look_at
from bim2rdt.perception.edges import EdgeFilter
from bim2rdt.perception.library import library_for
from bim2rdt.perception.visibility import DepthView, see_through_fraction

from tests.perception.conftest import DRUM, placed, render


def test_a_drum_mirrored_towards_the_camera_stands_where_the_camera_saw_through(site):
    drum = placed(DRUM, 15.5, 2.5)
    camera = look_at((12.5, 1.5, 1.1), (15.5, 2.5, 0.4))
    frame, _ = render(site, [drum], camera)
    view = DepthView(EdgeFilter().apply(frame.depth), frame.intrinsics, frame.T_world_camera)
    points, normals = library_for(site).families[DRUM].samples(3000)
    bar = PerceiveConfig().max_see_through
    assert see_through_fraction(drum.T_world_model, points, normals, view) < bar
    towards = camera[:3, 3] - drum.T_world_model[:3, 3]
    towards[2] = 0.0
    mirrored = drum.T_world_model.copy()
    mirrored[:3, 3] += 0.585 * towards / np.linalg.norm(towards)  # one diameter nearer: the seen arc on its back
    assert see_through_fraction(mirrored, points, normals, view) > 0.3
    away = drum.T_world_model.copy()
    away[:3, 3] -= 6.0 * towards / np.linalg.norm(towards)  # beyond the east wall: hidden, not seen through
    assert see_through_fraction(away, points, normals, view) < bar
