"""Procedural meshes of construction-site objects, at realistic sizes, in metres.

Every mesh is given in its body frame: upright along +z, resting on z = 0, centred on the origin in x and y.
Parts are concatenated (not booleaned): fine for ray casting and surface sampling, which is all they are for.
``MESH_LIBRARY`` maps the BIM family names used by the embedded site to their builders.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

from bim2rdt import exact
from bim2rdt.errors import Bim2RdtError
from bim2rdt.registration.so3 import axis_angle

_ROUND_SECTIONS = 32


def _box(extents: tuple[float, float, float], centre: tuple[float, float, float]) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=extents, transform=trimesh.transformations.translation_matrix(centre))


def _tube(start: tuple[float, float, float], end: tuple[float, float, float], radius: float) -> trimesh.Trimesh:
    """A 12-sided tube from ``start`` to ``end``: an upright one turned and moved there bit-exactly (trimesh's
    ``segment=`` turns it with a BLAS product, whose last bit follows the CPU)."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    axis = end - start
    length = float(exact.norm(axis))
    upright = trimesh.creation.cylinder(radius=radius, height=length, sections=12)
    T = np.eye(4)
    T[:3, :3] = _turn_up_to(axis / length)
    T[:3, 3] = (start + end) / 2.0
    return trimesh.Trimesh(exact.transform(T, upright.vertices), upright.faces, process=False)


def _turn_up_to(direction: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) taking +z onto the unit ``direction`` (about their common normal)."""
    normal = np.cross((0.0, 0.0, 1.0), direction)
    sine = float(exact.norm(normal))
    if sine < 1e-12:
        return np.eye(3) if direction[2] > 0 else np.diag([1.0, -1.0, -1.0])
    return axis_angle(normal / sine, np.array(np.arctan2(sine, direction[2])))


def _join(parts: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    mesh = trimesh.util.concatenate(parts)
    mesh.merge_vertices()
    return mesh


def traffic_cone(height: float = 0.70, base_width: float = 0.38) -> trimesh.Trimesh:
    """A 70 cm traffic cone: square rubber base (3 cm) and a truncated cone body."""
    base = _box((base_width, base_width, 0.03), (0.0, 0.0, 0.015))
    body_height = height - 0.03
    full_cone = trimesh.creation.cone(radius=0.15, height=body_height * 1.12, sections=_ROUND_SECTIONS)
    keep = full_cone.vertices[:, 2] <= body_height
    # truncate the tip: clamp the apex down to the body's height (a flat top of ~2 cm radius)
    full_cone.vertices[~keep, 2] = body_height
    full_cone.apply_translation((0.0, 0.0, 0.03))
    return _join([base, full_cone])


def steel_drum(height: float = 0.88, diameter: float = 0.585) -> trimesh.Trimesh:
    """A 55 US gallon (208 l) steel drum: a cylinder with two rolling hoops and a bung boss on the lid."""
    radius = diameter / 2
    shell = trimesh.creation.cylinder(radius=radius, height=height, sections=_ROUND_SECTIONS,
                                      transform=trimesh.transformations.translation_matrix((0, 0, height / 2)))
    hoops = [
        trimesh.creation.annulus(r_min=radius - 0.005, r_max=radius + 0.012, height=0.02, sections=_ROUND_SECTIONS,
                                 transform=trimesh.transformations.translation_matrix((0, 0, z)))
        for z in (height / 3, 2 * height / 3)
    ]
    bung = trimesh.creation.cylinder(radius=0.03, height=0.015, sections=12,
                                     transform=trimesh.transformations.translation_matrix(
                                         (radius * 0.6, 0.0, height + 0.0075)))
    return _join([shell, *hoops, bung])


def wooden_crate(length: float = 1.2, width: float = 0.8, height: float = 0.6) -> trimesh.Trimesh:
    """A 1200x800x600 wooden crate on two skids, with a lifting cleat on the +x end only (so it is not
    symmetric under a 180 degree yaw) and battens across the lid."""
    skid_h = 0.08
    body = _box((length, width, height - skid_h), (0.0, 0.0, skid_h + (height - skid_h) / 2))
    skids = [_box((length, 0.09, skid_h), (0.0, y, skid_h / 2)) for y in (-width / 2 + 0.1, width / 2 - 0.1)]
    cleat = _box((0.05, width * 0.5, 0.08), (length / 2 + 0.025, 0.0, height * 0.7))
    battens = [_box((0.08, width, 0.025), (x, 0.0, height + 0.0125)) for x in (-length / 3, length / 6)]
    return _join([body, *skids, cleat, *battens])


def eur_pallet() -> trimesh.Trimesh:
    """A EUR pallet (EPAL 1200x800x144): 5 top deck boards, 3 stringer boards, 9 blocks, 3 bottom boards."""
    length, width = 1.2, 0.8
    parts: list[trimesh.Trimesh] = []
    for y, board_w in zip((-0.3275, -0.16375, 0.0, 0.16375, 0.3275), (0.145, 0.1, 0.145, 0.1, 0.145)):
        parts.append(_box((length, board_w, 0.022), (0.0, y, 0.144 - 0.011)))
    block_ys = (-0.3275, 0.0, 0.3275)
    for y in block_ys:
        parts.append(_box((length, 0.145, 0.022), (0.0, y, 0.022 + 0.078 + 0.011)))  # stringer boards
        for x in (-0.5275, 0.0, 0.5275):
            parts.append(_box((0.145, 0.145, 0.078), (x, y, 0.022 + 0.039)))
    for x in (-0.5275, 0.0, 0.5275):
        parts.append(_box((0.145, width, 0.022), (x, 0.0, 0.011)))
    return _join(parts)


def survey_tripod(height: float = 1.5, foot_radius: float = 0.55) -> trimesh.Trimesh:
    """A surveying tripod: three thin legs (2.5 cm) from a head plate to feet 120 degrees apart, one leg
    carrying a clamp so the legs are distinguishable."""
    head_z = height - 0.04
    parts = [trimesh.creation.cylinder(radius=0.08, height=0.04, sections=_ROUND_SECTIONS,
                                       transform=trimesh.transformations.translation_matrix((0, 0, height - 0.02)))]
    for k, angle in enumerate(np.deg2rad([0.0, 120.0, 240.0])):
        foot = (foot_radius * np.cos(angle), foot_radius * np.sin(angle), 0.0125)
        top = (0.06 * np.cos(angle), 0.06 * np.sin(angle), head_z)
        parts.append(_tube(foot, top, 0.0125))
        if k == 0:
            clamp_at = 0.55
            centre = tuple(f + clamp_at * (t - f) for f, t in zip(foot, top))
            parts.append(_box((0.06, 0.06, 0.08), centre))
    mesh = _join(parts)
    mesh.apply_translation((0.0, 0.0, -mesh.bounds[0, 2]))  # slanted leg ends: rest the lowest rim on z = 0
    return mesh


def scaffold_frame(width: float = 1.0, height: float = 2.0, depth: float = 0.75) -> trimesh.Trimesh:
    """A scaffold bay of 48.3 mm tubes: four standards, ledgers at base and top, transoms, one diagonal brace
    on the front face, and a base plate under each standard."""
    r = 0.02415
    xs, ys = (-width / 2, width / 2), (-depth / 2, depth / 2)
    parts = [_tube((x, y, 0.01), (x, y, height), r) for x in xs for y in ys]
    parts += [_box((0.15, 0.15, 0.01), (x, y, 0.005)) for x in xs for y in ys]
    for z in (0.15, height - 0.05):
        parts += [_tube((xs[0], y, z), (xs[1], y, z), r) for y in ys]
        parts += [_tube((x, ys[0], z), (x, ys[1], z), r) for x in xs]
    parts.append(_tube((xs[0], ys[0], 0.15), (xs[1], ys[0], height - 0.05), r))
    return _join(parts)


def steel_i_beam(length: float = 3.0, depth: float = 0.31, flange_width: float = 0.165,
                 flange_t: float = 0.0097, web_t: float = 0.0058) -> trimesh.Trimesh:
    """A W12x26 steel I-beam (310 mm deep) lying on its bottom flange, length along x."""
    web_h = depth - 2 * flange_t
    bottom = _box((length, flange_width, flange_t), (0.0, 0.0, flange_t / 2))
    web = _box((length, web_t, web_h), (0.0, 0.0, flange_t + web_h / 2))
    top = _box((length, flange_width, flange_t), (0.0, 0.0, depth - flange_t / 2))
    return _join([bottom, web, top])


def worker(height: float = 1.78) -> trimesh.Trimesh:
    """A site worker standing (not a BIM family: nobody models people): legs, torso, arms, head and hard hat,
    1.78 m tall and 0.55 m across the shoulders, facing +x."""
    scale = height / 1.78
    parts = [_box((0.16, 0.15, 0.84), (0.0, y, 0.42)) for y in (-0.1, 0.1)]  # legs
    parts.append(_box((0.26, 0.42, 0.62), (0.0, 0.0, 1.15)))  # torso
    parts += [_box((0.1, 0.09, 0.62), (0.02, y, 1.13)) for y in (-0.255, 0.255)]  # arms
    parts.append(trimesh.creation.icosphere(subdivisions=2, radius=0.11).apply_translation((0.0, 0.0, 1.57)))
    parts.append(trimesh.creation.cylinder(radius=0.14, height=0.08, sections=_ROUND_SECTIONS,
                                           transform=trimesh.transformations.translation_matrix((0.0, 0.0, 1.70))))
    mesh = _join(parts)
    mesh.apply_scale(scale)
    return mesh


MESH_LIBRARY: dict[str, Callable[[], trimesh.Trimesh]] = {
    "Traffic_Cone_Orange_70cm": traffic_cone,
    "Steel_Drum_55gal": steel_drum,
    "Wooden_Crate_1200x800x600": wooden_crate,
    "Pallet_Wood_EUR": eur_pallet,
    "Survey_Tripod_Aluminium": survey_tripod,
    "Scaffold_Frame_1000x2000": scaffold_frame,
    "Steel_I-Beam_W12x26_A992": steel_i_beam,
}
"""BIM family name -> mesh builder (body frame, metres, upright +z)."""


class UnknownFamilyError(Bim2RdtError, KeyError):
    """No procedural mesh for a family name (a KeyError too, for callers that treat it as a lookup miss)."""

    def __str__(self) -> str:  # KeyError's own str() would quote the whole message
        return str(self.args[0])


def mesh_for_family(family: str) -> trimesh.Trimesh:
    """The mesh of a known site family; :class:`UnknownFamilyError` names the known families otherwise."""
    try:
        return MESH_LIBRARY[family]()
    except KeyError:
        known = ", ".join(sorted(MESH_LIBRARY))
        raise UnknownFamilyError(f"no mesh for family {family!r}; known: {known}") from None
