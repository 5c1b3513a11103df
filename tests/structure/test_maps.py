"""Deviation maps: a return's signed distance to the nearest permanent face (+ in front, towards the sensor), the
PNG per frame and the coloured PLY that CloudCompare reads (binary, uchar red/green/blue, a float deviation)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.sim.building import building_scene
from bim2rdt.sim.render import render_rgbd
from bim2rdt.structure import StructureConfig
from bim2rdt.structure.distances import FaceSamples
from bim2rdt.structure.maps import DeviationMaps
from bim2rdt.localization import depth_points


def test_a_point_in_front_of_a_wall_is_positive_behind_it_negative_and_far_from_all_is_nan(site_model):
    """The interior wall's west face is x = 11.85 m; the sensor stands west of it."""
    samples = FaceSamples.of(site_model, 0.02)
    centre = np.array([8.0, 10.0, 1.2])
    points = np.array([[11.82, 10.0, 1.2], [11.87, 10.0, 1.2], [8.5, 12.0, 1.5]])
    distances = samples.signed(points, centre, far=0.2)
    assert distances[0] == pytest.approx(0.03, abs=2e-3) and distances[1] == pytest.approx(-0.02, abs=2e-3)
    assert np.isnan(distances[2])  # 1.5 m from every face: not the structure's


def test_a_frame_gets_its_png_and_the_run_a_ply_with_colours_and_deviations(site_model, tmp_path):
    camera = look_at((5.0, 8.2, 1.1), (12.0, 8.5, 0.9))
    frame = render_rgbd(building_scene(site_model), Intrinsics(), camera, np.random.default_rng(0))
    frame = frame.as_frame(Intrinsics())
    points = depth_points(frame)
    shifted = camera.copy()
    shifted[0, 3] -= 0.03  # the pose 3 cm west: the wall facing it lands 3 cm in front of its face
    maps = DeviationMaps(site_model, tmp_path / "deviation", StructureConfig())
    png = maps.add(7, frame, points, shifted)
    assert png.name == "frame_007.png" and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ply = maps.finish(tmp_path / "deviation.ply")
    assert ply.read_bytes().startswith(b"ply\nformat binary_little_endian 1.0\n")
    cloud = trimesh.load(ply)
    colours = np.asarray(cloud.colors)[:, :3]
    deviation = np.asarray(cloud.metadata["_ply_raw"]["vertex"]["data"]["deviation"])
    assert len(cloud.vertices) == len(points) == len(deviation)
    world = points @ shifted[:3, :3].T + shifted[:3, 3]
    on_wall = (world[:, 0] > 11.8) & (world[:, 0] < 11.95) & (world[:, 2] > 0.3)
    assert on_wall.sum() > 1000
    assert np.nanmedian(deviation[on_wall]) == pytest.approx(0.03, abs=0.005)
    red = colours[on_wall].astype(int)
    assert np.median(red[:, 0] - red[:, 2]) > 80  # in front: the red end of the scale
    assert np.allclose(cloud.vertices, world, atol=1e-4)


def test_a_scan_without_an_image_gets_a_panorama_from_the_scanner(site_model, tmp_path):
    """A scan (no camera image): its PNG is the equirectangular view from the scanner, wall returns coloured."""
    import matplotlib.image

    pose = np.eye(4)
    pose[:3, 3] = (8.0, 10.0, 1.2)
    y, z = np.meshgrid(np.linspace(-1.0, 1.0, 60), np.linspace(-0.8, 1.0, 40))
    wall = np.column_stack([np.full(y.size, 11.85 - 8.0 - 0.02), y.ravel(), z.ravel()])  # 2 cm before its face
    maps = DeviationMaps(site_model, tmp_path / "deviation", StructureConfig())
    png = maps.add(0, object(), wall, pose)
    image = matplotlib.image.imread(png)
    assert image.shape[1] > image.shape[0] > 100
    cloud = trimesh.load(maps.finish(tmp_path / "deviation.ply"))
    deviation = np.asarray(cloud.metadata["_ply_raw"]["vertex"]["data"]["deviation"])
    assert np.median(deviation) == pytest.approx(0.02, abs=2e-3)
