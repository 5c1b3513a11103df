"""How much of each product there is, for progress: built quantity over total quantity.

A product's quantity comes from its ``IfcElementQuantity`` (Qto_WallBaseQuantities' NetVolume and friends) where
the file has one, else from its tessellated body: the enclosed volume of a closed mesh, else its surface area.
Quantities of different kinds do not add up, so one kind serves a whole set of products: volume (m³) when every
product has one, else area (m²) when every product has one, else a count (1 each).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.unit
import numpy as np

from bim2rdt.bim.model import BimModel

VOLUME_NAMES = ("NetVolume", "GrossVolume")
"""Base-quantity names of a product's volume, preferred first (IFC4 Qto_*BaseQuantities)."""
AREA_NAMES = ("NetSideArea", "GrossSideArea", "NetArea", "GrossArea", "NetSurfaceArea", "GrossSurfaceArea",
              "NetFootprintArea", "GrossFootprintArea", "Area")
"""Base-quantity names of a product's area, preferred first."""


@dataclass(frozen=True)
class Quantities:
    """One quantity per product, all of one ``kind`` ("volume" m³, "area" m² or "count"), keyed by GlobalId;
    ``sources`` says where each came from ("qto" or "mesh"; "count" for counts)."""

    kind: str
    values: dict[str, float]
    sources: dict[str, str]

    def total(self, global_ids: Iterable[str]) -> float:
        """The summed quantity of some products (0 for ones it does not know).

        Args:
            global_ids: GlobalIds of products.

        Returns:
            The sum, in the unit of ``kind``.
        """
        return float(sum(self.values.get(global_id, 0.0) for global_id in global_ids))


def product_quantities(model: BimModel, ifc: ifcopenshell.file | None, global_ids: Iterable[str]) -> Quantities:
    """The quantities of ``global_ids``, all of one kind (see the module).

    Args:
        model: The BIM (its meshes give quantities where the file has no IfcElementQuantity).
        ifc: The open IFC file, for its IfcElementQuantity; None uses the meshes only.
        global_ids: The products' GlobalIds.

    Returns:
        Their quantities, volume (m³) if every product has one, else area (m²) if every product has one, else a
            count.
    """
    ids = list(dict.fromkeys(global_ids))
    found = {global_id: _measures(model, ifc, global_id) for global_id in ids}
    for kind in ("volume", "area"):
        if ids and all(kind in measures for measures in found.values()):
            return Quantities(kind, {g: found[g][kind][0] for g in ids}, {g: found[g][kind][1] for g in ids})
    return Quantities("count", {g: 1.0 for g in ids}, {g: "count" for g in ids})


def _measures(model: BimModel, ifc: ifcopenshell.file | None, global_id: str) -> dict[str, tuple[float, str]]:
    """{"volume" | "area": (value in m³ | m², "qto" | "mesh")}: the file's quantities first, then the mesh's."""
    measures: dict[str, tuple[float, str]] = {}
    if model.has_mesh(global_id):
        volume, area = mesh_volume_area(*model.mesh(global_id))
        if volume is not None:
            measures["volume"] = (volume, "mesh")
        if area > 0.0:
            measures["area"] = (area, "mesh")
    if ifc is not None:
        measures.update(_qto_measures(ifc, global_id))
    return measures


def _qto_measures(ifc: ifcopenshell.file, global_id: str) -> dict[str, tuple[float, str]]:
    try:
        element = ifc.by_guid(global_id)
    except RuntimeError:
        return {}
    quantities: dict[str, float] = {}
    for qto in ifcopenshell.util.element.get_psets(element, qtos_only=True).values():
        quantities.update({name: value for name, value in qto.items() if isinstance(value, int | float)})
    measures = {}
    for kind, names, unit in (("volume", VOLUME_NAMES, "VOLUMEUNIT"), ("area", AREA_NAMES, "AREAUNIT")):
        value = next((quantities[name] for name in names if quantities.get(name, 0) > 0), None)
        if value is not None:
            measures[kind] = (float(value) * ifcopenshell.util.unit.calculate_unit_scale(ifc, unit), "qto")
    return measures


def mesh_volume_area(vertices: np.ndarray, faces: np.ndarray) -> tuple[float | None, float]:
    """The enclosed volume (m³; None unless every edge is shared by an even number of faces, as in closed shells,
    touching ones included) and the surface area (m²) of a triangle mesh.

    Args:
        vertices: (N,3) metres.
        faces: (M,3) vertex indices.

    Returns:
        (volume or None, area).
    """
    if len(faces) == 0:
        return None, 0.0
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    cross = np.cross(b - a, c - a)
    area = float(np.linalg.norm(cross, axis=1).sum() / 2.0)
    _, welded = np.unique(np.round(vertices, 6), axis=0, return_inverse=True)  # tessellators repeat vertices
    welded_faces = welded.reshape(-1)[faces]
    edges = np.sort(np.concatenate([welded_faces[:, [0, 1]], welded_faces[:, [1, 2]], welded_faces[:, [2, 0]]]),
                    axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    if np.any(counts % 2):  # every edge shared by an even number of faces: closed shells (touching ones too)
        return None, area
    volume = abs(float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0))
    return (volume if volume > 0.0 else None), area
