"""A localization tour of the embedded site: stations, the scene the camera sees there, and frames.

The scene is the site as built, by the simulator's building renderer: the BIM's permanent elements (walls,
columns, slab, door) where the model puts them, the site objects where
:func:`~bim2rdt.sim.reality.simulate_reality` moved them, and people standing in the views (clutter the map
does not have). Frames are ray cast by :func:`~bim2rdt.sim.render.render_rgbd`.

The default tour loops through the west hall and the south-east bay until it has walked 100 m (23 stations).
Most views see two walls or a wall and columns within 6 m; two of every ten face a single wall square on, so the position along it is
left to the odometry (degenerate fixes the filter must handle).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import trimesh

from bim2rdt.bim import BimModel
from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.perception.frame import Frame
from bim2rdt.sim.reality import simulate_reality
from bim2rdt.sim.render import render_rgbd
from bim2rdt.localization.planar import rz
from bim2rdt.sim.scene import BuildingPart, PlacedObject, SiteScene, ground_pose

CAMERA_HEIGHT = 1.1
LOOK_HEIGHT = 0.8

TOUR_STATIONS: tuple[tuple[float, float, float, float], ...] = (
    # camera x, y and the point it looks at, x, y (metres on the embedded site); walls within ~6 m of the camera
    (2.0, 4.0, 0.3, 0.3),     # the south-west corner: west and south walls
    (8.5, 2.0, 11.85, 6.5),   # the interior walls' ends and a column
    (11.0, 2.5, 11.0, 0.3),   # the south wall square on: degenerate along it
    (17.5, 1.2, 19.7, 6.0),   # the east wall and the interior wall of the south-east bay
    (18.0, 4.5, 12.0, 5.5),   # a column and the interior walls' ends
    (13.0, 4.0, 8.0, 9.0),    # columns and the interior wall's east face
    (9.0, 7.5, 11.0, 10.0),   # a column, the interior wall with its door, the north wall
    (4.0, 9.5, 0.3, 13.7),    # the north-west corner
    (5.0, 12.5, 5.0, 14.0),   # the north wall square on: degenerate along it
    (2.0, 8.0, 6.0, 10.0),    # a column and the north wall
)
"""One lap (about 46 m); later laps stand 0.3 m off each station, alternately up-right and down-left."""

PEOPLE_XY: tuple[tuple[float, float], ...] = ((1.2, 2.5), (11.3, 9.5), (19.0, 3.0), (3.5, 13.2))
"""Where people stand during the tour (in front of walls, in several views)."""


@dataclass(frozen=True)
class TourScene:
    """The as-built scene and its parts: which scene objects are permanent, site objects, people."""

    scene: SiteScene
    permanent: int
    site_objects: int
    people: int


def tour_poses(min_distance: float = 100.0, offset: float = 0.3) -> list[np.ndarray]:
    """True T_world_camera of the stations, lap after lap, until the straight-line path between them is at least
    ``min_distance`` m long (lap k stands k x ``offset`` m off in x and y, alternating sides)."""
    poses, walked, lap = [], 0.0, 0
    while True:
        shift = offset * ((lap + 1) // 2) * (1 if lap % 2 else -1)
        for x, y, tx, ty in TOUR_STATIONS:
            pose = look_at((x + shift, y + shift, CAMERA_HEIGHT), (tx, ty, LOOK_HEIGHT))
            if poses:
                walked += float(np.linalg.norm(pose[:2, 3] - poses[-1][:2, 3]))
            poses.append(pose)
            if walked >= min_distance:
                return poses
        lap += 1


def person() -> trimesh.Trimesh:
    """A standing person as a 0.5 x 0.3 x 1.75 m box on the slab (what a depth camera sees of one)."""
    return trimesh.creation.box(extents=(0.5, 0.3, 1.75),
                                transform=trimesh.transformations.translation_matrix((0.0, 0.0, 0.875)))


def tour_scene(model: BimModel, seed: int = 0, people: tuple[tuple[float, float], ...] = PEOPLE_XY,
               site_objects: bool = True, tolerance: float = 0.0) -> TourScene:
    """The embedded site as built (:func:`~bim2rdt.sim.reality.simulate_reality` with the building): the IFC's
    permanent elements where the BIM puts them give or take ``tolerance`` (1 sigma, m, per element and axis,
    and a tenth of a degree per centimetre in yaw: a building is set out to construction tolerance, not to the
    model), site objects as moved by ``seed`` (none without ``site_objects``), people standing at ``people``
    (x, y) as workers, and open ground around the building (what the camera sees through a doorway or from
    outside)."""
    proxies = [el.global_id for el in model.elements
               if el.ifc_class == "IfcBuildingElementProxy" and model.has_mesh(el.global_id)]
    built = simulate_reality(model, proxies if site_objects else [], seed=seed, building=True,
                             unplanned_at=(5.0, 4.0) if site_objects else None).scene
    crowd = [PlacedObject("person", person(), ground_pose(x, y, 0.3 * k), albedo=0.3, colour=(0.9, 0.5, 0.1))
             for k, (x, y) in enumerate(people)]
    building = [as_built(part, tolerance, rng) for part, rng in
                zip(built.building, np.random.default_rng(seed + 1).spawn(len(built.building)))]
    scene = SiteScene(built.objects, ground_size=60.0, building=building, workers=crowd)
    return TourScene(scene, len(built.building), len(built.objects), len(crowd))


def as_built(part: BuildingPart, tolerance: float, rng: np.random.Generator) -> BuildingPart:
    """The part set out off its design by a seeded shift (``tolerance`` m, 1 sigma per axis) and a turn about
    its centroid's vertical (0.1 deg per cm of ``tolerance``, 1 sigma)."""
    if tolerance <= 0.0:
        return part
    shift = rng.normal(0.0, tolerance, 3)
    turn = np.deg2rad(rng.normal(0.0, 10.0 * tolerance))
    centre = part.mesh.centroid
    T = np.eye(4)
    T[:3, :3] = rz(turn)
    T[:3, 3] = centre - rz(turn) @ centre + shift
    return replace(part, mesh=part.mesh.copy().apply_transform(T))


def render_frame(scene: SiteScene, T_world_camera: np.ndarray, rng: np.random.Generator,
                 intrinsics: Intrinsics = Intrinsics()) -> Frame:
    """A noisy RGB-D frame of the scene from the true camera pose."""
    return render_rgbd(scene, intrinsics, T_world_camera, rng).as_frame(intrinsics)
