"""The procedural mesh library: realistic sizes, upright, resting on the ground."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.sim.meshes import MESH_LIBRARY, mesh_for_family


@pytest.mark.parametrize("family", sorted(MESH_LIBRARY))
def test_every_mesh_rests_on_the_ground_centred_in_plan(family):
    mesh = mesh_for_family(family)
    lo, hi = mesh.bounds
    assert lo[2] == pytest.approx(0.0, abs=1e-9)
    centre_xy = (lo[:2] + hi[:2]) / 2
    assert np.all(np.abs(centre_xy) < 0.15), centre_xy


def test_sizes_match_the_family_names():
    cone_h = mesh_for_family("Traffic_Cone_Orange_70cm").extents[2]
    crate = mesh_for_family("Wooden_Crate_1200x800x600").extents
    assert cone_h == pytest.approx(0.70, abs=0.01)
    assert crate[1] == pytest.approx(0.8, abs=0.01)
    assert crate[2] == pytest.approx(0.6, abs=0.03)


def test_unknown_family_is_a_typed_one_line_error_naming_the_known_ones():
    from bim2rdt.errors import Bim2RdtError

    with pytest.raises(Bim2RdtError) as raised:
        mesh_for_family("Unobtainium_Widget")
    assert isinstance(raised.value, KeyError)  # still a lookup miss for callers that catch KeyError
    assert str(raised.value).startswith("no mesh for family 'Unobtainium_Widget'; known: ")
    assert "Steel_Drum_55gal" in str(raised.value) and "\n" not in str(raised.value)
