"""The as-built truth of a simulated site: what the robot's camera really sees, versus what the BIM says.

Site objects drift from their BIM placements (a crate pushed along the slab, a drum rolled and turned, a cone
knocked over) and objects nobody modelled appear (an unplanned drum). :func:`simulate_reality` draws such changes
from a seed and returns a ray-castable :class:`~bim2rdt.sim.scene.SiteScene` plus the truth per object, so a
mission's estimates can be scored. Meshes are the BIM's own (tessellated, brought back to each element's body
frame), so the simulation works for any IFC element with a body, not only the procedural library.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import trimesh

from bim2rdt.bim import BimModel
from bim2rdt.frames import UP
from bim2rdt.mission import Target
from bim2rdt.perception.library import element_body_mesh
from bim2rdt.registration.so3 import axis_angle
from bim2rdt.sim.building import DEFAULT_COLOUR, building_scene, element_colours
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.scene import PlacedObject, SiteScene, ground_pose
from bim2rdt.sim.site import SURFACE_COLOURS, UNBUILT_WALLS

UNPLANNED_FAMILY = "Steel_Drum_55gal"
"""The family of the unplanned object the default reality adds (a drum nobody put in the model)."""


@dataclass(frozen=True)
class TrueObject:
    """One object as it really is: its BIM GlobalId (None if unplanned), family, true pose and what changed."""

    global_id: str | None
    family: str
    T_world_model: np.ndarray
    change: str  # "unchanged" | "moved" | "knocked" | "unplanned" | "removed"


@dataclass(frozen=True)
class Reality:
    """The ray-castable site as built, and the truth for each of its objects (same order as ``scene.objects``);
    ``removed``: planned objects taken off the site (not in the scene; their BIM placement, change "removed")."""

    scene: SiteScene
    truth: list[TrueObject]
    removed: list[TrueObject] = field(default_factory=list)
    unbuilt: tuple[str, ...] = ()
    """GlobalIds of permanent elements the BIM plans that the site has not built (not in the scene)."""


body_mesh = element_body_mesh
"""An element's tessellated body in its own frame (perception's, which registers against the same mesh)."""


def simulate_reality(model: BimModel, global_ids: list[str], seed: int = 0, move_fraction: float = 0.5,
                     unplanned_at: tuple[float, float] | None = (5.0, 4.0), building: bool = False,
                     removed: int = 0, unbuilt: tuple[str, ...] | None = None) -> Reality:
    """Draw site changes for the objects ``global_ids``: about ``move_fraction`` of them moved by 0.15-0.6 m and
    turned by up to 40 degrees, one cone (if any) knocked 12 degrees off upright, ``removed`` of the unchanged
    ones taken off the site (the last ones in ``global_ids``' order), and an unplanned drum at ``unplanned_at``
    (x, y metres; None for none). ``unbuilt``: GlobalIds of permanent elements not built yet (None: the embedded
    site's :data:`~bim2rdt.sim.site.UNBUILT_WALLS`, by name, where the model has them). Deterministic for a seed (``removed`` leaves every other draw as it was). With
    ``building`` the scene is the model's building (walls occlude, the slab is the floor) with the objects in
    their IFC colours; without, the objects stand grey on an open ground plane. The truth is the same either way."""
    rng = np.random.default_rng(seed)
    truth = [_changed(model, gid, rng, move_fraction) for gid in global_ids]
    truth = _knock_one_cone(truth)
    if unplanned_at is not None:
        truth.append(TrueObject(None, UNPLANNED_FAMILY, ground_pose(*unplanned_at, yaw_rad=np.deg2rad(25.0)), "unplanned"))
    albedos = [0.35 + 0.3 * rng.random() for _ in truth]
    truth, albedos, gone = _take_away(truth, albedos, removed)
    if unbuilt is None:
        unbuilt = tuple(el.global_id for el in model.elements if el.ifc_class == "IfcWall" and el.name in UNBUILT_WALLS)
    return replace(_placed(model, global_ids, truth, albedos, building, unbuilt), removed=gone, unbuilt=unbuilt)


def _take_away(truth: list[TrueObject], albedos: list[float], count: int):
    """Take the last ``count`` unchanged objects off the site: (truth, albedos) left, the removed truth."""
    unchanged = [k for k, t in enumerate(truth) if t.change == "unchanged"]
    if count > len(unchanged):
        raise ValueError(f"cannot remove {count} objects: only {len(unchanged)} are unchanged")
    chosen = set(unchanged[len(unchanged) - count:]) if count else set()
    gone = [TrueObject(t.global_id, t.family, t.T_world_model, "removed") for k, t in enumerate(truth) if k in chosen]
    return ([t for k, t in enumerate(truth) if k not in chosen], [a for k, a in enumerate(albedos) if k not in chosen],
            gone)


def _placed(model: BimModel, global_ids: list[str], truth: list[TrueObject], albedos: list[float],
            building: bool, unbuilt: tuple[str, ...]) -> Reality:
    if not building:
        objects = [PlacedObject(t.family, _mesh(model, t), t.T_world_model, albedo=a) for t, a in zip(truth, albedos)]
        return Reality(SiteScene(objects, ground_size=60.0), truth)
    colours = element_colours(model, global_ids)
    objects = [PlacedObject(t.family, _mesh(model, t), t.T_world_model, a, _colour(t, colours))
               for t, a in zip(truth, albedos)]
    return Reality(building_scene(model, objects, unbuilt=unbuilt), truth)


def _colour(obj: TrueObject, colours: dict) -> tuple[float, float, float]:
    """The element's IFC colour; for an object the BIM lacks (or an unstyled one) its family's usual colour."""
    return colours.get(obj.global_id) or SURFACE_COLOURS.get(obj.family, DEFAULT_COLOUR)


def _changed(model: BimModel, global_id: str, rng: np.random.Generator, move_fraction: float) -> TrueObject:
    element = model.element(global_id)
    if rng.random() >= move_fraction:
        return TrueObject(global_id, element.family or "", element.placement.copy(), "unchanged")
    heading = rng.uniform(0.0, 2 * np.pi)
    shift = rng.uniform(0.15, 0.6) * np.array([np.cos(heading), np.sin(heading), 0.0])
    turn = axis_angle(UP, np.array(np.deg2rad(rng.uniform(-40.0, 40.0))))
    T = element.placement.copy()
    T[:3, :3] = turn @ T[:3, :3]
    T[:3, 3] += shift
    return TrueObject(global_id, element.family or "", T, "moved")


def _knock_one_cone(truth: list[TrueObject]) -> list[TrueObject]:
    """Lean the first cone 12 degrees about a horizontal axis through its base edge (it rests against
    something): a truly tilted object that a low upright bias must leave tilted."""
    for index, obj in enumerate(truth):
        if "cone" in obj.family.lower():
            lean = np.eye(4)
            lean[:3, :3] = axis_angle(np.array([1.0, 0.0, 0.0]), np.array(np.deg2rad(12.0)))
            pivot = np.eye(4)
            pivot[:3, 3] = (0.0, -0.19, 0.0)  # the base plate's edge that stays down (a +x turn lifts +y)
            T = obj.T_world_model @ pivot @ lean @ np.linalg.inv(pivot)
            truth[index] = TrueObject(obj.global_id, obj.family, T, "knocked")
            break
    return truth


def _mesh(model: BimModel, obj: TrueObject) -> trimesh.Trimesh:
    return mesh_for_family(obj.family) if obj.global_id is None else body_mesh(model, obj.global_id)


def objects_of_interest(model: BimModel) -> list[Target]:
    """The site objects the robot verifies: proxies (temporary works, materials, equipment) with a body."""
    return [Target(el.global_id, el.family or el.name or el.ifc_class, el.placement, body_mesh(model, el.global_id),
                   el.ifc_class)
            for el in model.elements if el.ifc_class == "IfcBuildingElementProxy" and model.has_mesh(el.global_id)]
