"""`bim2rdt verify` judges office1's structure (its prior 20 cm and 5 degrees off, its depth correction): the walls
and the slab it sees as planned with their coverage and signed distances, the wall behind the wardrobe not observed;
an IFC with the back wall moved 4 cm into the room makes it deviating by about that much; a wall added across the
clear floor is not built. Each run writes structure.json, a deviation PNG per frame and deviation.ply."""

from __future__ import annotations

import json

import ifcopenshell
import ifcopenshell.api
import ifcopenshell.util.placement
import ifcopenshell.util.representation
import numpy as np
import pytest
from typer.testing import CliRunner

from bim2rdt.cli import app

runner = CliRunner()
PRIOR, CORRECTION = "1.30,-4.55,1.38,82", "0.0605,0.0071,-0.0041"  # office1_verified's, rounded
BACK, LEFT, RIGHT, SLAB = ("2JZZFQ24DR6AR9VzB73DuV", "02UJOuQsPO7ufQ6Ge1Zyhz", "1ihtWmC1LPFgWT4P_fhWHu",
                           "340zJlvXHM4e3iHRiiwmVj")


def _verify(ifc, sensors, out):
    result = runner.invoke(app, ["verify", str(ifc), str(sensors / "pcl" / "office1.pcd"), "--out", str(out),
                                 "--json", "--prior", PRIOR, "--depth-correction", CORRECTION])
    assert result.exit_code == 0, result.output
    structure = {j["global_id"]: j for j in json.loads((out / "structure.json").read_text())}
    return json.loads(result.output), structure


@pytest.fixture(scope="module")
def office1(office1_verified):
    """The session's one run of office1.ifc (``office1_verified``: PRIOR and CORRECTION unrounded, from the truth)."""
    out = office1_verified.out
    structure = {j["global_id"]: j for j in json.loads((out / "structure.json").read_text())}
    return out, office1_verified.summary, structure


def test_office1s_walls_and_slab_are_judged_as_planned_with_coverage_and_deviation(office1):
    out, summary, structure = office1
    for global_id in (BACK, LEFT, SLAB):
        judged = structure[global_id]
        assert judged["status"] == "as planned", judged
        assert judged["coverage"] >= 0.1 and abs(judged["median_mm"]) < 15 and judged["frames"] == [0]
    assert structure[BACK]["coverage"] > 0.8  # the wall the camera faces
    assert structure[RIGHT]["status"] == "not observed"  # behind the wardrobe
    assert summary["structure"] == {"as planned": 4, "deviating": 0, "not built": 0, "not observed": 1}
    assert summary["verdicts"]["as planned"] == 5  # the furniture's verdicts are counted apart from the structure
    states = {e["global_id"]: e for e in json.loads((out / "twin.json").read_text())["elements"]}
    assert states[BACK]["status"] == "as planned" and states[BACK]["tolerance"]["name"] == "structure LOA30"
    assert states[RIGHT]["status"] == "not observed"
    assert (out / "deviation" / "frame_000.png").stat().st_size > 10_000
    assert (out / "deviation.ply").read_bytes().startswith(b"ply\nformat binary_little_endian 1.0\n")


def test_the_back_wall_moved_4_cm_into_the_room_is_deviating_by_about_that(sensors, tmp_path):
    ifc = ifcopenshell.open(str(sensors / "pcl" / "office1.ifc"))
    wall = ifc.by_guid(BACK)
    matrix = ifcopenshell.util.placement.get_local_placement(wall.ObjectPlacement)
    matrix[1, 3] -= 0.04  # the room is y < 0: the model's wall now stands 4 cm in front of the built one
    ifcopenshell.api.run("geometry.edit_object_placement", ifc, product=wall, matrix=matrix, is_si=True)
    ifc.write(str(tmp_path / "moved.ifc"))
    _, structure = _verify(tmp_path / "moved.ifc", sensors, tmp_path / "out")
    judged = structure[BACK]
    assert judged["status"] == "deviating", judged
    assert 0.025 <= judged["offset_m"][1] <= 0.05 and judged["median_mm"] < -20  # built 4 cm behind the model
    assert structure[LEFT]["status"] == structure[SLAB]["status"] == "as planned"
    states = {e["global_id"]: e for e in json.loads((tmp_path / "out" / "twin.json").read_text())["elements"]}
    assert states[BACK]["status"] == "deviating"


def test_a_wall_added_across_the_clear_floor_is_not_built(sensors, tmp_path):
    """0.8 m long, 1 m high, 1.7 m in front of the camera: the floor and the chair are seen through it."""
    ifc = ifcopenshell.open(str(sensors / "pcl" / "office1.ifc"))
    body = ifcopenshell.util.representation.get_context(ifc, "Model", "Body", "MODEL_VIEW")
    wall = ifcopenshell.api.run("root.create_entity", ifc, ifc_class="IfcWall", name="Added wall")
    shape = ifcopenshell.api.run("geometry.add_wall_representation", ifc, context=body, length=0.8, height=1.0,
                                 thickness=0.1)
    ifcopenshell.api.run("geometry.assign_representation", ifc, product=wall, representation=shape)
    placement = np.eye(4)
    placement[:3, 3] = (1.5, -2.95, 0.0)
    ifcopenshell.api.run("geometry.edit_object_placement", ifc, product=wall, matrix=placement, is_si=True)
    ifcopenshell.api.run("spatial.assign_container", ifc, products=[wall],
                         relating_structure=ifc.by_type("IfcBuildingStorey")[0])
    ifc.write(str(tmp_path / "added.ifc"))
    summary, structure = _verify(tmp_path / "added.ifc", sensors, tmp_path / "out")
    assert structure[wall.GlobalId]["status"] == "not built", structure[wall.GlobalId]
    assert structure[BACK]["status"] == "as planned" and summary["verdicts"]["as planned"] == 5
    states = {e["global_id"]: e for e in json.loads((tmp_path / "out" / "twin.json").read_text())["elements"]}
    assert states[wall.GlobalId]["status"] == "not built"
