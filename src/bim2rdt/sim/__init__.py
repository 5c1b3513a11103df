"""bim2rdt.sim: the synthetic site (procedural meshes, an RGB-D camera by ray casting) and the paper's
registration scenarios S1-S4."""

from bim2rdt.sim.render import RgbdFrame, render_rgbd
from bim2rdt.sim.scenarios import SCENARIOS, ObjectTrial, Scenario, scenario
from bim2rdt.sim.scene import PlacedObject, SiteScene

__all__ = ["SCENARIOS", "ObjectTrial", "PlacedObject", "RgbdFrame", "Scenario", "SiteScene", "render_rgbd",
           "scenario"]
