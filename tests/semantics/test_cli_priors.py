"""`bim2rdt priors`: the table/JSON of priors from an IFC file or a family list, and its exit codes."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from fake_llm_server import Reply, completion


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", "priors", *args], capture_output=True, text=True,
                          timeout=120)


def test_families_option_prints_a_table_with_label_bias_and_source():
    result = run_cli("--families", "Traffic_Cone_Orange_70cm,Zzyzx 12")
    assert result.returncode == 0, result.stderr
    assert "traffic cone" in result.stdout and "0.45" in result.stdout
    assert "knowledge-base" in result.stdout and "default" in result.stdout
    assert "1 unknown" in result.stdout


def test_json_output_lists_every_family_with_its_prior():
    result = run_cli("--families", "Steel_I-Beam_W12x26_A992, Ladder, Steel_Drum_55gal", "--json")
    assert result.returncode == 0, result.stderr
    rows = {row["family"]: row for row in json.loads(result.stdout)}  # strict JSON: no Infinity
    assert rows["Steel_I-Beam_W12x26_A992"]["symmetry"] == 2 and rows["Steel_Drum_55gal"]["symmetry"] == "inf"
    assert rows["Steel_I-Beam_W12x26_A992"]["label"] == "steel I-beam"
    assert rows["Steel_I-Beam_W12x26_A992"]["yaw_only"] is True
    assert rows["Ladder"]["upright_bias"] == pytest.approx(0.2)


@pytest.mark.samples
def test_every_building_element_of_the_real_samples_gets_a_known_upright_prior(samples):
    structural = ("IfcWall", "IfcSlab", "IfcDoor", "IfcWindow", "IfcBeam", "IfcStair", "IfcRailing",
                  "IfcRoof", "IfcFooting", "IfcCovering", "IfcMember")
    for path in sorted(samples.glob("*.ifc")):
        result = run_cli(str(path), "--json")
        assert result.returncode == 0, f"{path.name}: {result.stderr}"
        rows = json.loads(result.stdout)
        building = [row for row in rows if row["ifc_class"].startswith(structural)]
        assert building, path.name
        for row in building:
            assert row["known"] and row["yaw_only"] and row["upright_bias"] >= 0.9, (path.name, row)


@pytest.mark.samples
def test_revit_and_archicad_sample_families_are_recognised_by_name(samples):
    expected = {
        "Basic Wall:Exterior - Brick on Block": "brick wall",
        "M_W-Wide Flange:W410X60": "steel I-beam",
        "Wall Foundation:Bearing Footing - 900 x 300": "footing",
        "Stair:Residential - 200mm Max Riser 250mm Tread": "stair",
        "Railing:1100mm Guard Rail": "railing",
        "Leichtbeton 102890359 240": "lightweight concrete wall",   # named by material: the IFC entity says wall
        "Sparren-7": "rafter",
        "Eingangstür": "door",
    }
    labels = {}
    for name in ("Duplex_A_20110907.ifc", "AC20-FZK-Haus.ifc"):
        result = run_cli(str(samples / name), "--json")
        labels.update({row["family"]: row["label"] for row in json.loads(result.stdout)})
    assert {family: labels.get(family) for family in expected} == expected


def test_a_missing_file_exits_1_with_one_line():
    result = run_cli("/no/such/file.ifc")
    assert result.returncode == 1
    assert result.stderr.strip().count("\n") == 0 and "/no/such/file.ifc" in result.stderr


def test_a_file_that_is_not_ifc_exits_1_with_one_line(tmp_path):
    junk = tmp_path / "junk.ifc"
    junk.write_text("this is not STEP\n")
    result = run_cli(str(junk))
    assert result.returncode == 1
    assert "junk.ifc" in result.stderr and result.stderr.strip().count("\n") == 0


def test_neither_file_nor_families_is_a_usage_error():
    result = run_cli()
    assert result.returncode == 2
    assert "--families" in result.stderr


def test_help_describes_the_command():
    result = run_cli("--help")
    assert result.returncode == 0
    assert "upright bias" in result.stdout


def test_llm_option_asks_the_configured_endpoint_once_then_uses_the_cache(llm_server, monkeypatch):
    monkeypatch.setenv("BIM2RDT_LLM__BASE_URL", llm_server.url)
    monkeypatch.setenv("BIM2RDT_LLM__API_KEY", "sk-test")
    monkeypatch.setenv("BIM2RDT_LLM__MODEL", "test-model")
    llm_server.answers = {"Traffic_Cone_Orange_70cm": ("traffic cone", 0.3, False)}
    first = run_cli("--families", "Traffic_Cone_Orange_70cm", "--llm", "--json")
    second = run_cli("--families", "Traffic_Cone_Orange_70cm", "--llm", "--json")
    assert first.returncode == 0 and second.returncode == 0, first.stderr + second.stderr
    assert json.loads(first.stdout)[0]["source"] == "llm"
    assert json.loads(first.stdout)[0]["upright_bias"] == 0.3
    assert json.loads(second.stdout)[0]["source"] == "llm-cache"
    assert len(llm_server.requests) == 1


def test_llm_option_with_a_failing_endpoint_still_exits_0_with_fallback_priors(llm_server, monkeypatch):
    monkeypatch.setenv("BIM2RDT_LLM__BASE_URL", llm_server.url)
    monkeypatch.setenv("BIM2RDT_LLM__MAX_RETRIES", "0")
    llm_server.then(Reply(body=completion("no json here")))
    result = run_cli("--families", "Ladder", "--llm")
    assert result.returncode == 0, result.stderr
    assert "knowledge-base (llm" in result.stdout and "0.2" in result.stdout
