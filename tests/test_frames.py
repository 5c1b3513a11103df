"""The world frame's shared constants: one home, read-only, so no caller can bend every package's up."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.frames import UP


def test_the_world_up_is_the_unit_z_axis_and_cannot_be_written_into():
    assert np.array_equal(UP, [0.0, 0.0, 1.0])
    with pytest.raises(ValueError):
        UP[2] = -1.0


def test_perception_pulls_fits_upright_along_the_shared_up():
    from bim2rdt.perception import fitting, naming, slab

    assert fitting.UP is UP and naming.UP is UP
    assert slab.off_the_slab.__defaults__[2] is UP
