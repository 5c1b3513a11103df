"""The building in the simulated camera's view: the IFC's permanent elements as ray-castable world meshes, with
the IFC's own surface colours (or a colour per class where the file has none) and a finish that textures them.

With the building in the scene walls occlude what stands behind them, columns hide objects, and the camera sees
slab, walls and doors around the objects, as a robot's camera does.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence

import trimesh

from bim2rdt.bim import BimElement, BimModel
from bim2rdt.perception.structure import permanent_elements
from bim2rdt.sim.scene import BuildingPart, Colour, PlacedObject, SiteScene
from bim2rdt.sim.styles import surface_colours

CLASS_COLOURS: dict[str, Colour] = {
    "IfcWall": (0.66, 0.65, 0.62), "IfcSlab": (0.58, 0.57, 0.55), "IfcColumn": (0.70, 0.69, 0.66),
    "IfcBeam": (0.62, 0.61, 0.58), "IfcDoor": (0.52, 0.36, 0.21), "IfcWindow": (0.40, 0.48, 0.52),
    "IfcRoof": (0.45, 0.30, 0.25), "IfcStair": (0.64, 0.63, 0.60), "IfcRailing": (0.35, 0.35, 0.37),
}
"""Colour (RGB 0-1) of elements whose IFC carries no surface style, by class (``StandardCase`` and friends
share their base class's)."""
DEFAULT_COLOUR: Colour = (0.6, 0.6, 0.6)


def building_parts(model: BimModel, colours: dict[str, Colour] | None = None,
                   unbuilt: Collection[str] = ()) -> list[BuildingPart]:
    """The model's permanent elements as :class:`BuildingPart` (world meshes, metres). ``colours``
    ({GlobalId: RGB}) defaults to the IFC file's own surface styles (read from ``model.path``).

    Args:
        model: The BIM, loaded with geometry.
        colours: {GlobalId: RGB 0-1}; None reads the IFC file's surface styles (class colours where none).
        unbuilt: GlobalIds of permanent elements the site has not built yet (left out).

    Returns:
        One part per permanent element: GlobalId, IFC class, world mesh (metres), colour and finish.
    """
    elements = [el for el in permanent_elements(model) if el.global_id not in unbuilt]
    if colours is None:
        colours = element_colours(model, [el.global_id for el in elements])
    parts = []
    for el in elements:
        vertices, faces = model.mesh(el.global_id)
        parts.append(BuildingPart(el.global_id, el.ifc_class, trimesh.Trimesh(vertices, faces, process=False),
                                  colours.get(el.global_id) or class_colour(el.ifc_class), finish(el)))
    return parts


def element_colours(model: BimModel, global_ids: Iterable[str]) -> dict[str, Colour]:
    """{GlobalId: RGB} from the IFC's surface styles; empty when the file is gone (a model read from cache)."""
    if not model.path.is_file():
        return {}
    return surface_colours(model.path, global_ids)


def class_colour(ifc_class: str) -> Colour:
    """The default colour of an IFC class (see :data:`CLASS_COLOURS`)."""
    return CLASS_COLOURS.get(_base_class(ifc_class), DEFAULT_COLOUR)


def finish(element: BimElement) -> str:
    """Which procedural finish textures an element (see :mod:`bim2rdt.sim.surfaces`): blockwork for block,
    brick and masonry walls, a floated slab for slabs, a door leaf for doors, cast concrete otherwise."""
    base = _base_class(element.ifc_class)
    name = f"{element.family or ''} {element.name or ''}".lower()
    if base == "IfcWall" and any(word in name for word in ("block", "brick", "masonry", "mauerwerk")):
        return "blockwork"
    return {"IfcSlab": "slab", "IfcDoor": "door", "IfcWindow": "plain", "IfcRailing": "plain"}.get(base, "concrete")


def building_scene(model: BimModel, objects: Sequence[PlacedObject] = (),
                   workers: Sequence[PlacedObject] = (), unbuilt: Collection[str] = ()) -> SiteScene:
    """A scene of the model's building (no ground plane: the building's slabs are the floor) with ``objects``
    and ``workers`` in it.

    Args:
        model: The BIM, loaded with geometry.
        objects: Site objects placed in the world.
        workers: Workers placed in the world.
        unbuilt: GlobalIds of permanent elements the site has not built yet (left out of the scene).

    Returns:
        The scene, ready to render.
    """
    return SiteScene(list(objects), ground_size=0.0, building=building_parts(model, unbuilt=unbuilt),
                     workers=list(workers))


def _base_class(ifc_class: str) -> str:
    for suffix in ("StandardCase", "ElementedCase"):
        if ifc_class.endswith(suffix):
            return ifc_class[: -len(suffix)]
    return {"IfcStairFlight": "IfcStair", "IfcCurtainWall": "IfcWall"}.get(ifc_class, ifc_class)

