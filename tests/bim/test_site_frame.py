"""The site frame: map conversion both ways, geodetic anchor and true north from real files."""

from __future__ import annotations

import numpy as np
import pytest


def test_world_points_go_to_map_coordinates_and_back(site_model):
    frame = site_model.site_frame
    world = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [3.0, 4.0, 1.5]])
    on_map = frame.to_map(world)
    angle = np.radians(12.0)
    # absolute tolerance: rel=1e-6 of a 5.43e6 m northing would be 5 m, hiding a dropped rotation
    assert on_map[1] == pytest.approx([456000 + 10 * np.cos(angle), 5430000 + 10 * np.sin(angle), 115.0], abs=1e-6)
    assert np.allclose(frame.to_world(on_map), world)
    assert np.linalg.norm(on_map[2] - on_map[0]) == pytest.approx(np.linalg.norm(world[2]))


def test_a_site_reference_point_and_true_north_are_read_from_archicad(sample_model):
    frame = sample_model("AC20-FZK-Haus.ifc").site_frame
    assert frame.source == "IfcSite" and frame.georeferenced
    assert frame.latitude_deg == pytest.approx(49.100435, abs=1e-6)
    assert frame.longitude_deg == pytest.approx(8.436539, abs=1e-6)
    assert frame.elevation_m == pytest.approx(110.0)
    assert frame.true_north_deg == pytest.approx(-50.0, abs=1e-6)  # TrueNorth (0.766, 0.643)


def test_a_west_longitude_keeps_its_sign(sample_model):
    frame = sample_model("Duplex_A_20110907.ifc").site_frame
    assert frame.longitude_deg == pytest.approx(-87.6394, abs=1e-4)


def test_a_file_without_geo_reference_says_so(sample_model):
    frame = sample_model("construction_scheduling_task.ifc").site_frame
    assert frame.source == "none" and not frame.georeferenced
    with pytest.raises(ValueError, match="no map conversion"):
        frame.to_map(np.zeros((1, 3)))
