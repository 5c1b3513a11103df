"""structure.json: the judgements' fields, written and read back; bad entries and views are one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bim2rdt.structure import (StructureError, StructureJudgement, StructureView, read_structure_json,
                               write_structure_json)

FIELDS = {"global_id", "ifc_class", "status", "coverage", "median_mm", "p95_mm", "offset_m", "rotation_deg",
          "frames", "reason", "built_share"}


def test_structure_json_holds_exactly_the_contracts_fields_and_reads_back(tmp_path):
    judged = [StructureJudgement("a", "IfcWall", "deviating", 0.8, -31.5, 80.0, (0.0, 0.03, 0.0), 0.4, [0, 2], "off"),
              StructureJudgement("b", "IfcSlab", "not observed", 0.0, reason="not in view of any frame")]
    path = write_structure_json(judged, tmp_path / "structure.json")
    entries = json.loads(path.read_text())
    assert [set(e) for e in entries] == [FIELDS, FIELDS]
    assert entries[0]["offset_m"] == [0.0, 0.03, 0.0] and entries[1]["offset_m"] is None
    assert read_structure_json(path) == judged


def test_an_unknown_status_or_a_missing_field_is_refused(tmp_path):
    path = tmp_path / "structure.json"
    path.write_text(json.dumps([{**{f: None for f in FIELDS}, "global_id": "a", "ifc_class": "IfcWall",
                                 "status": "built", "coverage": 1.0, "frames": [], "reason": ""}]))
    with pytest.raises(StructureError, match="unknown structure status 'built'"):
        read_structure_json(path)
    path.write_text(json.dumps([{"global_id": "a"}]))
    with pytest.raises(StructureError, match="every field"):
        read_structure_json(path)


def test_a_view_needs_n_by_3_points_and_a_finite_pose():
    with pytest.raises(StructureError, match=r"points_sensor must be \(N, 3\)"):
        StructureView(0, np.zeros((5, 2)), np.eye(4))
    pose = np.eye(4)
    pose[0, 3] = np.nan
    with pytest.raises(StructureError, match="finite 4x4"):
        StructureView(1, np.zeros((5, 3)), pose)


def test_a_view_with_no_return_on_any_face_judges_nothing_and_a_model_element_never_seen_is_not_observed(
        site_model):
    from bim2rdt.structure import judge_structure

    pose = np.eye(4)
    pose[:3, 3] = (10.0, 7.0, 1.2)
    sky = np.array([[0.0, 0.0, 50.0], [0.1, 0.0, 60.0]])  # two returns far above the open-topped building
    judged = judge_structure(site_model, [StructureView(0, sky, pose)])
    assert judged and all(j.status == "not observed" for j in judged)
    assert {j.ifc_class for j in judged} >= {"IfcWall", "IfcSlab", "IfcColumn", "IfcDoor"}


def test_the_built_share_round_trips_and_a_file_written_before_it_reads_as_none(tmp_path):
    judged = [StructureJudgement("a", "IfcWall", "deviating", 0.5, reason="partly built", built_share=0.45)]
    path = write_structure_json(judged, tmp_path / "structure.json")
    assert json.loads(path.read_text())[0]["built_share"] == 0.45 and read_structure_json(path) == judged
    older = [{k: v for k, v in entry.items() if k != "built_share"} for entry in json.loads(path.read_text())]
    path.write_text(json.dumps(older))
    assert read_structure_json(path)[0].built_share is None
