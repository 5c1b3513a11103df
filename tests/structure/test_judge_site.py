"""The structure judge on simulated frames of the embedded site: a camera in the west room facing the interior
wall (x = 11.85 m), its door and three columns. As built: every element in view as planned; the wall left out of
the rendered site: not built; the wall built 4 cm east with the pose leaning 2 cm onto it: that wall alone
deviating, by 4 cm (the pose is fixed on the others)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.sim.building import building_parts
from bim2rdt.sim.render import render_rgbd
from bim2rdt.sim.scene import SiteScene
from bim2rdt.structure import STRUCTURE_STATUSES, StructureView, judge_structure
from bim2rdt.localization import depth_points

WALL = "2Bau$NfuHQWgIBDszY$vLS"  # Interior Wall - North/South, x 11.85-12 m
CAMERA = look_at((5.0, 8.2, 1.1), (12.0, 8.5, 0.9))


def _judged(model, parts, pose=CAMERA):
    frame = render_rgbd(SiteScene([], 0.0, parts), Intrinsics(), CAMERA, np.random.default_rng(0))
    view = StructureView(0, depth_points(frame.as_frame(Intrinsics())), pose)
    return {j.global_id: j for j in judge_structure(model, [view])}


@pytest.fixture(scope="module")
def parts(site_model):
    return building_parts(site_model)


def test_as_built_every_element_in_view_is_as_planned_on_its_faces(site_model, parts):
    judged = _judged(site_model, parts)
    seen = [j for j in judged.values() if j.status != "not observed"]
    assert {j.ifc_class for j in seen} >= {"IfcWall", "IfcColumn", "IfcSlab", "IfcDoor"}
    assert all(j.status == "as planned" for j in seen), [(j.ifc_class, j.reason) for j in seen]
    wall = judged[WALL]
    assert wall.coverage > 0.9 and abs(wall.median_mm) < 2 and wall.p95_mm < 40 and wall.frames == [0]
    assert all(j.status in STRUCTURE_STATUSES for j in judged.values())
    hidden = [j for j in judged.values() if j.ifc_class == "IfcWall" and j.coverage == 0]
    assert hidden and all(j.status == "not observed" for j in hidden)  # walls behind the camera


def test_a_wall_left_out_of_the_site_is_not_built_and_the_rest_stays_as_planned(site_model, parts):
    judged = _judged(site_model, [p for p in parts if p.global_id != WALL])
    assert judged[WALL].status == "not built", judged[WALL].reason
    others = [j for j in judged.values() if j.global_id != WALL and j.status != "not observed"]
    assert others and all(j.status == "as planned" for j in others), [(j.ifc_class, j.reason) for j in others]


def test_a_wall_built_4_cm_off_its_line_is_deviating_even_from_a_pose_that_leans_onto_it(site_model, parts):
    """The pose given is 2 cm east of the true one, as a fix pulled by the moved wall would be: the judge refits
    it on the door and the columns, which outvote the wall."""
    moved = [dataclasses.replace(p, mesh=p.mesh.copy().apply_translation([0.04, 0.0, 0.0]))
             if p.global_id == WALL else p for p in parts]
    leaning = CAMERA.copy()
    leaning[0, 3] += 0.02
    judged = _judged(site_model, moved, leaning)
    wall = judged[WALL]
    assert wall.status == "deviating", wall.reason
    assert wall.offset_m[0] == pytest.approx(0.04, abs=0.004) and abs(wall.median_mm + 40) < 4
    others = [j for j in judged.values() if j.global_id != WALL and j.status != "not observed"]
    assert len(others) >= 4 and all(j.status == "as planned" for j in others), [(j.ifc_class, j.reason)
                                                                                 for j in others]


def test_a_wall_built_to_half_its_height_is_partly_built_and_carries_the_share_built(site_model, parts):
    """The wall standing to 1.5 m of its 3 m: seen through above, built below. Not "not built" (most of it is not
    seen through), but deviating as partly built, with the share of its face in clear view built (about half),
    which progress weighs its volume by; the whole wall is built (1.0) and the missing one not (0.0)."""
    import trimesh

    def half(part):
        mesh = trimesh.intersections.slice_mesh_plane(part.mesh, plane_normal=(0.0, 0.0, -1.0),
                                                      plane_origin=(0.0, 0.0, 1.5))  # open on top: unseen from 1.1 m
        return dataclasses.replace(part, mesh=mesh)

    judged = _judged(site_model, [half(p) if p.global_id == WALL else p for p in parts])
    wall = judged[WALL]
    assert wall.status == "deviating" and "partly built" in wall.reason, wall.reason
    assert 0.3 < wall.built_share < 0.7, wall.reason
    whole = _judged(site_model, parts)[WALL]
    missing = _judged(site_model, [p for p in parts if p.global_id != WALL])[WALL]
    assert (whole.built_share, missing.built_share) == (1.0, 0.0)


PARTITION_VIEW = look_at((15.5, 9.5, 1.1), (17.6, 13.0, 1.0))
"""The north-east room from its south-west: the partition (x 17.6 m, y 12.5-13.7 m) before the east and north
exterior walls it meets."""


def test_the_unbuilt_ne_partition_is_not_built_and_the_walls_seen_through_its_place_stay_as_planned(site_model, parts):
    """Left out of the site, the partition is seen through (the east wall behind it) except where its face meets
    the north wall: returns there lie on both, and count for neither, so it reads not built. Seen through, it
    takes no part in the pose the others are measured from: its few returns 5 cm behind its face would have pulled
    that pose onto it, and the east wall, measured from it, read 60 mm off (as the demo's read 16 mm)."""
    from bim2rdt.sim.site import PARTITION

    partition = next(el.global_id for el in site_model.elements if el.name == PARTITION[0])
    walls = {el.global_id: el.name for el in site_model.elements if el.name in ("Exterior Wall - East",
                                                                               "Exterior Wall - North")}
    frame = render_rgbd(SiteScene([], 0.0, [p for p in parts if p.global_id != partition]), Intrinsics(),
                        PARTITION_VIEW, np.random.default_rng(0))
    judged = {j.global_id: j for j in judge_structure(
        site_model, [StructureView(0, depth_points(frame.as_frame(Intrinsics())), PARTITION_VIEW)])}
    assert judged[partition].status == "not built" and judged[partition].built_share == 0.0, judged[partition].reason
    for global_id, name in walls.items():
        assert judged[global_id].status == "as planned", (name, judged[global_id].reason)
        assert np.linalg.norm(judged[global_id].offset_m) < 0.005, (name, judged[global_id].offset_m)


def test_a_thin_leaf_keeps_its_returns_decisive_though_its_back_face_lies_within_the_band(site_model, parts):
    """The door's 50 mm leaf cut to its lower half: the doorway above it is seen through, the leaf below returns on
    its face with its own back face 5 cm behind, inside the 10 cm band. Those returns still say the leaf stands,
    so the door is seen through over about half (an opening the model lacks), not over 90 % (open)."""
    import trimesh

    door = next(el.global_id for el in site_model.elements if el.ifc_class == "IfcDoor")
    cut = [dataclasses.replace(p, mesh=trimesh.intersections.slice_mesh_plane(p.mesh, (0.0, 0.0, -1.0),
                                                                               (0.0, 0.0, 1.05)))
           if p.global_id == door else p for p in parts]
    judged = _judged(site_model, cut)[door]
    assert judged.status == "deviating" and "opening the model lacks" in judged.reason, judged.reason
