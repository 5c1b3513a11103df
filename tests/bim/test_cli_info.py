"""`bim2rdt info` and `bim2rdt bench ifc`: output, JSON, and exit codes (0 ok, 1 bad input, 2 usage)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=300)


def test_info_prints_schema_unit_storeys_classes_and_families(site_ifc):
    result = run_cli("info", str(site_ifc))
    assert result.returncode == 0, result.stderr
    for expected in ("IFC4", "metre", "Ground Floor", "IfcBuildingElementProxy", "Traffic_Cone_Orange_70cm"):
        assert expected in result.stdout


def test_info_json_with_readiness_is_one_machine_readable_document(site_ifc):
    result = run_cli("info", str(site_ifc), "--readiness", "--json")
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)
    assert payload["schema"] == "IFC4" and payload["unit_scale"] == 1.0
    assert payload["counts_by_class"]["IfcColumn"] == 6
    assert payload["families"]["Traffic_Cone_Orange_70cm"] == 3
    assert payload["site_frame"]["crs"] == "EPSG:25832"
    checks = {c["name"]: c["status"] for c in payload["readiness"]}
    assert checks["families the prior table does not know"] == "pass"
    assert checks["geo-reference"] == "pass"


def test_info_on_a_model_without_geo_reference_warns(samples):
    result = run_cli("info", str(samples / "construction_scheduling_task.ifc"), "--readiness", "--json")
    payload = json.loads(result.stdout)
    assert result.returncode == 0
    assert payload["unit"] == "inch" and payload["unit_scale"] == 0.0254
    assert {c["name"]: c["status"] for c in payload["readiness"]}["geo-reference"] == "warn"


def test_info_on_bad_input_exits_1_with_one_line(tmp_path):
    (tmp_path / "junk.ifc").write_text("not a model\n")
    for path in (tmp_path / "absent.ifc", tmp_path / "junk.ifc"):
        result = run_cli("info", str(path))
        assert result.returncode == 1
        assert result.stderr.strip().count("\n") == 0 and result.stderr.startswith("error:")


def test_info_without_a_file_is_a_usage_error():
    assert run_cli("info").returncode == 2


def test_bench_ifc_reports_both_figures_as_json(site_ifc):
    result = run_cli("bench", "ifc", "--file", str(site_ifc), "--repeat", "1", "--json")
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)
    assert payload["shapes"] == payload["meshes"] == 27  # the partition of the schedule's task S.5 included
    for contender in ("bare_loop", "load", "cached"):
        assert payload[contender]["wall_s"] > 0 and payload[contender]["cpu_s"] > 0
    assert payload["overhead"] == payload["load"]["cpu_s"] / payload["bare_loop"]["cpu_s"] - 1


def test_info_on_a_file_with_a_duplicate_id_exits_1_in_one_line_instead_of_crashing(site_text):
    slab = site_text.line(r"=IFCSLAB\(")  # ifcopenshell 0.9 segfaults tessellating this file (exit 139)
    before = site_text.text.splitlines()[site_text.line_number(slab) - 2]
    path = site_text.replace(slab, slab.replace(f"#{site_text.entity_id(slab)}=", f"#{site_text.entity_id(before)}="))
    result = run_cli("info", str(path))
    assert result.returncode == 1
    assert result.stderr.startswith("error: variant.ifc: entity id #") and result.stderr.count("\n") == 1


def test_info_lists_warnings_and_strict_fails_on_them_after_the_report(site_text):
    wall = site_text.line(r"=IFCWALL\(")
    placement = re.search(r",(#\d+),#\d+,\$,\.SOLIDWALL\.", wall).group(1)
    path = site_text.replace(wall, wall.replace(f",{placement},", ",#999999,"))
    plain = run_cli("info", "--no-geometry", "--json", str(path))
    assert plain.returncode == 0
    [warning] = json.loads(plain.stdout)["warnings"]
    assert warning["kind"] == "dangling reference" and "#999999" in warning["message"]
    strict = run_cli("info", "--no-geometry", "--strict", str(path))
    assert strict.returncode == 1 and "Reader warnings (1)" in strict.stdout
    assert strict.stderr.startswith("error: variant.ifc: --strict: #") and strict.stderr.count("\n") == 1


def test_info_strict_passes_a_clean_file(site_ifc):
    result = run_cli("info", "--strict", str(site_ifc))
    assert result.returncode == 0, result.stderr
    assert "Reader warnings" not in result.stdout


def test_the_default_samples_folder_is_shared_beside_this_checkout():
    """Not two levels up: with the checkout at /x/main the samples are /x/shared/data/ifc, never /shared."""
    from bim2rdt.config import default_samples_dir

    checkout = Path(__file__).resolve().parents[2]
    assert default_samples_dir() == checkout.parent / "shared" / "data" / "ifc"


def test_bench_ifc_without_a_file_takes_the_office_model_from_the_default_folder(samples, monkeypatch):
    from bim2rdt.cli.bim import BENCH_FILE, _default_bench_file
    from bim2rdt.config import default_samples_dir, get_settings

    if not (default_samples_dir() / BENCH_FILE).is_file():
        pytest.skip(f"{default_samples_dir()} has no {BENCH_FILE}")
    monkeypatch.delenv("BIM2RDT_SAMPLES", raising=False)
    get_settings.cache_clear()
    assert _default_bench_file() == default_samples_dir() / BENCH_FILE
