"""The depth check measures planar BIM faces only: a synthetic corner whose walls meet at 89.5 degrees, with a
spiral stair (IfcStair) in view, is not flagged and the stair is never one of the compared faces; the same view
through a bent depth (office1's raw Kinect bend) is flagged (the old check, treads grouped by orientation, fitted
the stair as one plane meeting the slab at 72 degrees here: the real sweep's false alarm); the BIM's faces group coplanar triangles, and a
stair's treads or a curved wall's facets never make a face."""

from __future__ import annotations

import math

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.project
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import numpy as np
import pytest
import trimesh

from bim2rdt.bim import load_ifc
from bim2rdt.localization.cloud import OccludedMap, scan_points
from bim2rdt.perception import look_at
from bim2rdt.sim.site import yaw_pose
from bim2rdt.verify import check_depth
from bim2rdt.verify.chain import real_sensor_localization
from bim2rdt.verify.faces import PlanarFaces


class _Ifc:
    """A one-storey IFC4 built with ifcopenshell's api: boxes (extruded rectangles) as elements."""

    def __init__(self) -> None:
        self.ifc = ifcopenshell.api.project.create_file(version="IFC4")
        project = ifcopenshell.api.root.create_entity(self.ifc, "IfcProject", name="corner")
        ifcopenshell.api.unit.assign_unit(self.ifc, length={"is_metric": True, "raw": "METERS"})
        model = ifcopenshell.api.context.add_context(self.ifc, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(self.ifc, context_type="Model", context_identifier="Body",
                                                         target_view="MODEL_VIEW", parent=model)
        site = ifcopenshell.api.root.create_entity(self.ifc, "IfcSite", name="site")
        building = ifcopenshell.api.root.create_entity(self.ifc, "IfcBuilding", name="building")
        self.storey = ifcopenshell.api.root.create_entity(self.ifc, "IfcBuildingStorey", name="Level 0")
        ifcopenshell.api.aggregate.assign_object(self.ifc, products=[site], relating_object=project)
        ifcopenshell.api.aggregate.assign_object(self.ifc, products=[building], relating_object=site)
        ifcopenshell.api.aggregate.assign_object(self.ifc, products=[self.storey], relating_object=building)

    def _solid(self, size, at=(0.0, 0.0, 0.0), turn_deg=0.0):
        c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
        profile = self.ifc.create_entity(
            "IfcRectangleProfileDef", ProfileType="AREA", XDim=size[0], YDim=size[1],
            Position=self.ifc.create_entity("IfcAxis2Placement2D",
                                            Location=self.ifc.create_entity("IfcCartesianPoint", (0.0, 0.0))))
        return self.ifc.create_entity(
            "IfcExtrudedAreaSolid", SweptArea=profile, Depth=size[2],
            ExtrudedDirection=self.ifc.create_entity("IfcDirection", (0.0, 0.0, 1.0)),
            Position=self.ifc.create_entity(
                "IfcAxis2Placement3D", Location=self.ifc.create_entity("IfcCartesianPoint", tuple(map(float, at))),
                Axis=self.ifc.create_entity("IfcDirection", (0.0, 0.0, 1.0)),
                RefDirection=self.ifc.create_entity("IfcDirection", (c, s, 0.0))))

    def element(self, ifc_class: str, items, at=(0.0, 0.0, 0.0), yaw_deg: float = 0.0):
        """An element of ``ifc_class`` whose body is ``items`` (solids in its own frame), placed at ``at``."""
        element = ifcopenshell.api.root.create_entity(self.ifc, ifc_class, name=ifc_class)
        ifcopenshell.api.spatial.assign_container(self.ifc, products=[element], relating_structure=self.storey)
        representation = self.ifc.create_entity("IfcShapeRepresentation", ContextOfItems=self.body,
                                                RepresentationIdentifier="Body", RepresentationType="SweptSolid",
                                                Items=items)
        ifcopenshell.api.geometry.assign_representation(self.ifc, product=element, representation=representation)
        ifcopenshell.api.geometry.edit_object_placement(self.ifc, product=element,
                                                        matrix=yaw_pose(*at, yaw_deg), is_si=True)
        return element

    def corner(self, wall_angle_deg: float):
        """A slab, a wall along x at y = 6 and a wall from the origin at ``wall_angle_deg`` to it, a column, and
        a spiral stair of 14 treads (0.9 x 0.3 m, 18 cm rise, 25 degrees apart) around (4.5, 4)."""
        self.element("IfcSlab", [self._solid((10.0, 10.0, 0.2), (4.0, 4.0, -0.2))])
        self.element("IfcWall", [self._solid((9.0, 0.2, 3.0), (4.5, 0.1, 0.0))], at=(0.0, 6.0, 0.0))
        self.element("IfcWall", [self._solid((9.0, 0.2, 3.0), (4.5, -0.1, 0.0))], at=(0.0, 6.0, 0.0),
                     yaw_deg=-wall_angle_deg)
        self.element("IfcColumn", [self._solid((0.3, 0.3, 3.0), (0.0, 0.0, 0.0))], at=(5.8, 5.2, 0.0))
        treads = [self._solid((0.9, 0.3, 0.05), (0.6 * math.cos(math.radians(25 * k)),
                                                 0.6 * math.sin(math.radians(25 * k)), 0.18 * (k + 1)), 25 * k)
                  for k in range(14)]
        return self.element("IfcStair", treads, at=(4.5, 4.0, 0.0))


def _depth_view(model, T_world_camera: np.ndarray, step: int = 4, noise: float = 0.003) -> np.ndarray:
    """A pinhole depth view (525 px focal, 640 x 480, every ``step``-th pixel) of every body of ``model``, as
    sensor-frame points with noise along the rays: rendered here, not by the code under test."""
    meshes = [trimesh.Trimesh(*model.mesh(el.global_id), process=False) for el in model.elements
              if model.has_mesh(el.global_id)]
    mesh = trimesh.util.concatenate(meshes)
    v, u = np.mgrid[0:480:step, 0:640:step]
    rays = np.stack([(u.ravel() - 320) / 525.0, (v.ravel() - 240) / 525.0, np.ones(u.size)], axis=1)
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    origin = T_world_camera[:3, 3]
    hits, index, _ = mesh.ray.intersects_location(np.broadcast_to(origin, rays.shape), rays @ T_world_camera[:3, :3].T,
                                                  multiple_hits=False)
    ranges = np.linalg.norm(hits - origin, axis=1) + np.random.default_rng(1).normal(0, noise, len(hits))
    return rays[index] * ranges[:, None]


def _bent(points: np.ndarray, g=(0.0605, 0.0071, -0.0041)) -> np.ndarray:
    """The inverse of office1's depth correction p_true = p / (1 - g.p): how its raw Kinect saw a true point."""
    return points / (1.0 + points @ np.asarray(g))[:, None]


@pytest.fixture(scope="module")
def corner(tmp_path_factory):
    folder = tmp_path_factory.mktemp("corner")
    builder = _Ifc()
    stair = builder.corner(89.5)
    builder.ifc.write(str(folder / "corner.ifc"))
    model = load_ifc(folder / "corner.ifc", cache_dir=folder / "cache")
    T = look_at((6.5, 1.0, 1.5), (2.0, 5.5, 0.9))
    return model, stair.GlobalId, T, _depth_view(model, T)


def _check(model, T, points):
    config = real_sensor_localization()
    scan = scan_points(type("Cloud", (), {"points": points})(), config)
    return check_depth(scan, OccludedMap.of(model), T, config.max_range)


def test_a_corner_at_89_5_degrees_with_a_spiral_stair_in_view_is_not_flagged_and_the_stair_is_no_face(corner):
    model, stair, T, points = corner
    check = _check(model, T, points)
    assert not check.miscalibrated, check.reason
    compared = {p.first for p in check.pairs} | {p.second for p in check.pairs}
    walls = {el.global_id for el in model.elements if el.ifc_class == "IfcWall"}
    assert walls <= compared, "both walls in view are measured"
    assert stair not in compared
    wall_pair = next(p for p in check.pairs if {p.first, p.second} == walls)
    assert wall_pair.bim_deg == pytest.approx(89.5, abs=0.05)
    assert abs(wall_pair.error_deg) < 1.0
    entry = check.to_dict()["plane_pairs"][0]
    assert entry["first_face"]["points"] >= 150 and len(entry["first_face"]["normal"]) == 3


def test_the_same_corner_seen_through_office1s_raw_depth_bend_is_flagged(corner):
    model, _, T, points = corner
    check = _check(model, T, _bent(points))
    assert check.miscalibrated and "deg" in check.reason


def test_a_stairs_treads_and_a_curved_walls_facets_never_make_a_face(corner):
    model = corner[0]
    scene = OccludedMap.of(model)
    faces = PlanarFaces.of(scene.permanent.mesh, np.asarray(scene.permanent.face_owner),
                           scene.permanent.element_classes)
    owners = {scene.permanent.element_classes[k] for k in faces.owner}
    assert owners <= {"IfcSlab", "IfcWall", "IfcColumn"} and "IfcColumn" in owners
    assert scene.permanent.element_classes.count("IfcStair") == 1, "the stair is in the map: it could be measured"
    # a curved wall, a ring 3 m tall tessellated into 64 facets: no facet, nor its flat top, holds 10 % of it
    ring = trimesh.creation.annulus(r_min=2.0, r_max=2.2, height=3.0, sections=64)
    assert len(PlanarFaces.of(ring, np.zeros(len(ring.faces), int), ("IfcWall",))) == 0
    box = trimesh.creation.box((3.0, 0.2, 3.0))
    assert len(PlanarFaces.of(box, np.zeros(len(box.faces), int), ("IfcWall",))) == 2  # its two sides
