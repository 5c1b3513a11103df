"""Procedural finishes of the building's surfaces: what gives a wall, a column or a slab real corners.

A camera looking at a painted box sees no corners in its faces; a site does: blockwork has mortar joints in
running bond, cast concrete has formwork panel joints and tie holes on a grid, a slab has saw-cut bays and
grime. Each finish is an albedo factor (0-1) of a world point on a surface with a given normal; the colour
(the IFC's surface style, or the class default) multiplies it. Coordinates are world metres, so a static
building's texture stays put between frames (what a localiser tracks).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from bim2rdt.sim.scene import texture

FINISHES = ("concrete", "blockwork", "slab", "door", "plain")


def finish_albedo(finish: str, points_world: np.ndarray, normals_world: np.ndarray) -> np.ndarray:
    """Albedo factor (N,) of points (N, 3) on surfaces with normals (N, 3) for a finish in :data:`FINISHES`."""
    return _FINISH[finish](points_world, normals_world)


def in_plane(points_world: np.ndarray, normals_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface coordinates (h, v) in metres: (x, y) on floors and ceilings; on walls h runs along the wall (x or
    y, whichever the face is not facing) and v is the height z."""
    flat = np.abs(normals_world[:, 2]) > 0.7
    facing_x = np.abs(normals_world[:, 0]) > np.abs(normals_world[:, 1])
    h = np.where(flat, points_world[:, 0], np.where(facing_x, points_world[:, 1], points_world[:, 0]))
    v = np.where(flat, points_world[:, 1], points_world[:, 2])
    return h, v


def _near_grid(coordinate: np.ndarray, pitch: float, half_width: float, offset: float = 0.0) -> np.ndarray:
    phase = np.mod(coordinate - offset, pitch)
    return np.minimum(phase, pitch - phase) < half_width


def _blockwork(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """440 x 215 mm blocks (joints included) in running bond, 10 mm light mortar joints, block-to-block shade."""
    h, v = in_plane(points, normals)
    course = np.floor(v / 0.215)
    shifted = h + 0.22 * (course % 2)
    joint = _near_grid(v, 0.215, 0.005) | _near_grid(shifted, 0.44, 0.005)
    block_shade = texture(np.c_[np.floor(shifted / 0.44), course, np.zeros_like(h)], cell=1.0, contrast=0.3)
    return np.where(joint, 1.15, 0.85 * block_shade * texture(points, cell=0.05, contrast=0.1))


def _concrete(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Cast concrete: 1.2 x 0.6 m formwork panels with dark joints, 3 cm tie holes on a 0.6 m grid, mottling."""
    h, v = in_plane(points, normals)
    joint = _near_grid(h, 1.2, 0.006) | _near_grid(v, 0.6, 0.006)
    tie = _near_grid(h, 0.6, 0.015, 0.3) & _near_grid(v, 0.6, 0.015, 0.3)
    mottle = texture(points, cell=0.12, contrast=0.25)
    return np.where(tie, 0.25, np.where(joint, 0.6, mottle))


def _slab(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """A power-floated slab: 1 m saw-cut bays with dark joints and 20 cm grime patches."""
    h, v = in_plane(points, normals)
    joint = _near_grid(h, 1.0, 0.01) | _near_grid(v, 1.0, 0.01)
    return np.where(joint, 0.65, texture(points, cell=0.2, contrast=0.25))


def _door(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """A flush door: veneer with grain streaks and scuffs (a door leaf has few corners, as in life)."""
    h, v = in_plane(points, normals)
    grain = 0.9 + 0.1 * np.sin(h * 90.0 + 3.0 * np.sin(v * 7.0))
    return grain * texture(points, cell=0.1, contrast=0.2)


def _plain(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    return texture(points, cell=0.1, contrast=0.2)


_FINISH: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "concrete": _concrete, "blockwork": _blockwork, "slab": _slab, "door": _door, "plain": _plain}
