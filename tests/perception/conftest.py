"""Fixtures of the perception tests: the embedded site read once, and frames rendered inside its building."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.perception import Intrinsics
from bim2rdt.perception.library import library_for
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.building import building_scene
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.render import render_rgbd
from bim2rdt.sim.scene import PlacedObject, ground_pose
from bim2rdt.sim.site import SURFACE_COLOURS, build_site_ifc
from bim2rdt.sim.tof import TofEffects

CONE, DRUM = "Traffic_Cone_Orange_70cm", "Steel_Drum_55gal"


@pytest.fixture(scope="session")
def site(tmp_path_factory):
    folder = tmp_path_factory.mktemp("perception-site")
    return load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")


@pytest.fixture(scope="session")
def priors(site):
    return KnowledgeBasePriors().priors(sorted(library_for(site).families))


def placed(family: str, x: float, y: float, yaw_deg: float = 0.0) -> PlacedObject:
    return PlacedObject(family, mesh_for_family(family), ground_pose(x, y, np.deg2rad(yaw_deg)),
                        colour=SURFACE_COLOURS[family])


def element(site, family: str, index: int = 0):
    """The ``index``-th BIM element of ``family`` on the embedded site."""
    return [el for el in site.elements if el.family == family][index]


def render(site, objects, camera, workers=(), seed=0, tof=TofEffects()):
    """(what the robot sends, the rendered frame with labels) of ``objects`` inside the site's building."""
    rendered = render_rgbd(building_scene(site, objects, workers), Intrinsics(), camera, np.random.default_rng(seed),
                           tof=tof)
    return rendered.as_frame(Intrinsics()), rendered
