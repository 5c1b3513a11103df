"""Shared values of the twin tests: a site time, the embedded site's symmetry orders and family meshes."""

from __future__ import annotations

import math

import numpy as np

from bim2rdt.sim.meshes import mesh_for_family

SYMMETRY = {"Traffic_Cone_Orange_70cm": 4, "Steel_Drum_55gal": math.inf, "Pallet_Wood_EUR": 2}
T0 = 1_780_000_000.0
"""A site time (UTC s) the tests start from."""


def family_mesh(family: str):
    mesh = mesh_for_family(family)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)
