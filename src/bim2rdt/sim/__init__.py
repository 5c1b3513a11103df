"""bim2rdt.sim: the synthetic site (procedural meshes, the IFC's building, an RGB-D camera by ray casting) and the
paper's registration scenarios S1-S4."""

from bim2rdt.sim.building import building_parts, building_scene
from bim2rdt.sim.render import RgbdFrame, render_rgbd
from bim2rdt.sim.scenarios import SCENARIOS, ObjectTrial, Scenario, scenario
from bim2rdt.sim.scene import BuildingPart, PlacedObject, SiteScene

__all__ = ["SCENARIOS", "BuildingPart", "ObjectTrial", "PlacedObject", "RgbdFrame", "Scenario", "SiteScene",
           "building_parts", "building_scene", "render_rgbd", "scenario"]
