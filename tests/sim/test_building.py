"""The building in the simulated camera's view: walls occlude, surfaces carry the IFC's colours and corners."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.perception import Frame
from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.perception.corners import shi_tomasi
from bim2rdt.sim.building import building_parts, building_scene
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.render import cast_frame, render_rgbd
from bim2rdt.sim.scene import MISS, STRUCTURE, PlacedObject, SiteScene, ground_pose
from bim2rdt.sim.site import SURFACE_COLOURS, build_site_ifc
from bim2rdt.sim.styles import surface_colours

CONE = "Traffic_Cone_Orange_70cm"


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    folder = tmp_path_factory.mktemp("site")
    return load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")


def _cone_at(x: float, y: float, colour=None) -> PlacedObject:
    return PlacedObject(CONE, mesh_for_family(CONE), ground_pose(x, y, 0.0), 0.5, colour)


def test_an_object_behind_a_wall_is_hidden_and_seen_without_the_building(model):
    """The interior wall runs along x = 11.85-12 m from y = 6 to 13.85 m; the camera stands west of it."""
    camera = look_at((9.5, 11.0, 1.1), (13.5, 11.0, 0.4))
    behind = _cone_at(13.5, 11.0)
    open_site = cast_frame(SiteScene([behind]), Intrinsics(), camera)
    walled = cast_frame(building_scene(model, [behind]), Intrinsics(), camera)
    assert np.count_nonzero(open_site.labels == 0) > 1000
    assert np.count_nonzero(walled.labels == 0) == 0
    wall_ids = {part.global_id for part in building_parts(model) if part.ifc_class == "IfcWall"}
    centre_part = building_parts(model)[walled.part[240, 320]]
    assert walled.labels[240, 320] == STRUCTURE and centre_part.global_id in wall_ids
    assert walled.depth[240, 320] == pytest.approx((11.85 - 9.5) / camera[0, 2], abs=0.01)  # along the optical axis


def test_building_parts_are_the_permanent_elements_with_their_ifc_colours(model):
    parts = building_parts(model)
    assert sorted({p.ifc_class for p in parts}) == ["IfcColumn", "IfcDoor", "IfcSlab", "IfcWall"]
    colours = {p.ifc_class: p.colour for p in parts}
    assert colours["IfcSlab"] == pytest.approx(SURFACE_COLOURS["Slab"])
    assert colours["IfcDoor"] == pytest.approx(SURFACE_COLOURS["Door"])
    assert {p.finish for p in parts if p.ifc_class == "IfcWall"} == {"concrete", "blockwork"}


def test_an_orange_cone_renders_orange_and_the_grey_image_is_its_luma(model):
    proxies = [el.global_id for el in model.elements if el.family == CONE]
    colour = surface_colours(model.path, proxies)[proxies[0]]
    frame = cast_frame(building_scene(model, [_cone_at(5.0, 3.0, colour)]), Intrinsics(),
                       look_at((5.0, 0.8, 1.1), (5.0, 3.0, 0.35)))
    red, green, blue = (frame.rgb[frame.labels == 0].astype(float).mean(axis=0))
    assert red > 1.5 * green > 1.5 * blue
    luma = frame.rgb.astype(float) @ [0.299, 0.587, 0.114]
    assert np.abs(frame.gray - luma).max() <= 1.0


def test_walls_have_corners_a_camera_can_track(model):
    """Blockwork joints and formwork ties: a bare wall in view gives Shi-Tomasi corners on the wall itself."""
    frame = cast_frame(building_scene(model), Intrinsics(), look_at((10.0, 3.0, 1.5), (10.0, 0.0, 1.5)))
    uv = shi_tomasi(frame.gray, (0, 0, 640, 480), max_corners=600).astype(int)
    on_wall = frame.labels[uv[:, 1], uv[:, 0]] == STRUCTURE
    assert np.count_nonzero(on_wall) >= 100


def test_a_rendered_frame_is_a_valid_perception_frame(model):
    frame = render_rgbd(building_scene(model), Intrinsics(), look_at((4.0, 4.0, 1.1), (8.0, 8.0, 0.5)),
                        np.random.default_rng(0))
    robot = frame.as_frame(Intrinsics())
    assert isinstance(robot, Frame) and robot.rgb.dtype == np.uint8 and robot.depth.dtype == np.float32
    assert np.array_equal(robot.valid_depth, frame.labels != MISS)  # no return from the sky above the walls


def test_a_grey_scene_renders_no_rgb_as_before():
    """The registration scenarios' scenes (no building, no colours) keep the grey-only renderer."""
    frame = cast_frame(SiteScene([_cone_at(0.0, 0.0)]), Intrinsics(), look_at((0.0, -2.5, 1.0), (0.0, 0.0, 0.35)))
    assert frame.rgb is None and frame.part is None and frame.colour.shape == (480, 640, 3)


def test_surface_colours_come_from_material_styles_in_a_real_archicad_file(samples):
    path = samples / "AC20-FZK-Haus.ifc"
    sample = load_ifc(path)
    walls = [el.global_id for el in sample.elements if el.ifc_class.startswith("IfcWall")]
    colours = surface_colours(path, walls)
    assert len(colours) >= 0.8 * len(walls)
    assert all(0.0 <= c <= 1.0 for rgb in colours.values() for c in rgb)


def test_a_reality_with_the_building_has_the_same_truth_and_coloured_objects(model):
    from bim2rdt.sim.reality import objects_of_interest
    from bim2rdt.sim.reality import simulate_reality

    ids = [t.global_id for t in objects_of_interest(model)]
    open_site, walled = simulate_reality(model, ids, seed=3), simulate_reality(model, ids, seed=3, building=True)
    assert [t.change for t in open_site.truth] == [t.change for t in walled.truth]
    assert all(np.array_equal(a.T_world_model, b.T_world_model) for a, b in zip(open_site.truth, walled.truth))
    assert walled.scene.building and walled.scene.ground_size == 0.0
    cones = [o for o in walled.scene.objects if o.family == CONE]
    assert cones and all(o.colour == pytest.approx(SURFACE_COLOURS[CONE]) for o in cones)
