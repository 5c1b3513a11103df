"""Footprints of meshes in the robot's height band: exact plan shapes, filled solids, no guessed fills."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from bim2rdt.planning.frame import GridFrame
from bim2rdt.planning.raster import disc_cells, mesh_cells, polygon_cells

FRAME = GridFrame((0.0, 0.0), 0.05, (120, 120))
BAND = (0.05, 1.2)


def box(extents, centre):
    return trimesh.creation.box(extents=extents, transform=trimesh.transformations.translation_matrix(centre))


def cells_of(mesh, band=BAND, frame=FRAME):
    found = mesh_cells(mesh.vertices, mesh.faces, band, frame)
    if found is None:
        return None
    row0, col0, mask = found
    whole = np.zeros(frame.shape, bool)
    whole[row0:row0 + mask.shape[0], col0:col0 + mask.shape[1]] = mask
    return whole


def centres_inside(low, high, frame=FRAME):
    rows, cols = np.mgrid[0:frame.shape[0], 0:frame.shape[1]]
    centres = frame.centres(rows, cols)
    return np.all((centres > low) & (centres < high), axis=-1)


def test_a_box_standing_through_the_band_fills_its_plan_rectangle_to_within_a_cell():
    footprint = cells_of(box((1.0, 0.5, 3.0), (2.0, 3.0, 1.5)))
    assert footprint[centres_inside((1.5, 2.75), (2.5, 3.25))].all()  # solid, not an outline
    assert not footprint[~centres_inside((1.5 - 0.05, 2.75 - 0.05), (2.5 + 0.05, 3.25 + 0.05))].any()


def test_a_box_above_or_below_the_band_has_no_footprint():
    assert cells_of(box((1.0, 1.0, 0.5), (2.0, 2.0, 2.0))) is None
    assert cells_of(box((1.0, 1.0, 0.04), (2.0, 2.0, 0.02))) is None


def test_a_table_top_inside_the_band_blocks_the_whole_table_not_only_its_legs():
    legs = [box((0.05, 0.05, 0.72), (x, y, 0.36)) for x in (1.0, 2.0) for y in (1.0, 2.0)]
    table = trimesh.util.concatenate([*legs, box((1.1, 1.1, 0.03), (1.5, 1.5, 0.735))])
    assert cells_of(table)[centres_inside((1.0, 1.0), (2.0, 2.0))].all()


def test_overlapping_parts_of_one_mesh_fill_their_union_without_a_hole():
    """Library meshes are parts concatenated, not booleaned: even-odd alone would hollow out the overlap."""
    mesh = trimesh.util.concatenate([box((1.0, 1.0, 2.0), (2.0, 2.0, 1.0)), box((1.0, 1.0, 2.0), (2.5, 2.5, 1.0))])
    footprint = cells_of(mesh)
    assert footprint[centres_inside((2.0, 2.0), (2.5, 2.5))].all()
    assert footprint[centres_inside((1.5, 1.5), (3.0, 3.0)) & ~centres_inside((2.5, 1.5), (3.0, 2.0))
                     & ~centres_inside((1.5, 2.5), (2.0, 3.0))].all()


def test_a_solid_whose_faces_are_wound_inwards_still_comes_out_filled():
    solid = box((1.0, 1.0, 2.0), (2.0, 2.0, 1.0))
    inverted = trimesh.Trimesh(solid.vertices, solid.faces[:, ::-1], process=False)
    assert cells_of(inverted)[centres_inside((1.5, 1.5), (2.5, 2.5))].all()


def test_an_open_surface_gives_its_line_and_no_guessed_fill():
    quad = trimesh.Trimesh([[1.0, 1.0, 0.0], [4.0, 1.0, 0.0], [4.0, 1.0, 2.0], [1.0, 1.0, 2.0]], [[0, 1, 2], [0, 2, 3]])
    footprint = cells_of(quad)
    assert 55 <= footprint.sum() <= 2 * 62
    assert not footprint[centres_inside((0.0, 1.2), (6.0, 6.0))].any()


def test_a_roof_sloping_down_into_the_band_blocks_only_where_it_is_lower_than_the_band_top():
    """A plane from z = 0.2 at x = 1 up to z = 2.2 at x = 5: under 1.2 m for x < 3."""
    roof = trimesh.Trimesh([[1.0, 1.0, 0.2], [5.0, 1.0, 2.2], [5.0, 3.0, 2.2], [1.0, 3.0, 0.2]], [[0, 1, 2], [0, 2, 3]])
    footprint = cells_of(roof)
    assert footprint[centres_inside((1.05, 1.05), (2.95, 2.95))].all()
    assert not footprint[centres_inside((3.1, 0.0), (6.0, 6.0))].any()


def test_the_band_is_in_world_heights_so_an_upper_storey_sees_only_its_own_things():
    on_upper = box((1.0, 1.0, 1.0), (2.0, 2.0, 3.5))
    assert cells_of(on_upper, band=(3.05, 4.2)) is not None
    assert cells_of(on_upper) is None


def test_polygons_and_discs_cover_the_cells_whose_centres_they_hold():
    row0, col0, mask = polygon_cells([(1.0, 1.0), (2.0, 1.0), (2.0, 3.0), (1.0, 3.0)], FRAME)
    assert mask.sum() == pytest.approx(20 * 40, rel=0.12)
    row0, col0, mask = disc_cells((3.0, 3.0), 1.0, FRAME)
    assert mask.sum() == pytest.approx(np.pi * 20 ** 2, rel=0.03)
    assert disc_cells((30.0, 30.0), 1.0, FRAME) is None
