"""`bim2rdt verify` on the real office1 Kinect frame: localization against the truth file, every furniture box as
planned, an edited IFC (one box moved 30 cm, one deleted) giving deviating and new, the uncorrected depth giving
a miscalibration warning and no deviating verdict, and bad input in one line."""

from __future__ import annotations

import json
import math
import sys
import zipfile

import ifcopenshell
import ifcopenshell.api
import ifcopenshell.util.placement
import numpy as np
import pytest
from typer.testing import CliRunner

from bim2rdt.cli import app

runner = CliRunner()
MOVED, DELETED = "3AvJHIZibIA8Zc4nF02Aem", "1JLifEocPP8vfgeQqgMYaa"  # the desk, cupboard B


def _truth(sensors):
    return json.loads((sensors / "pcl" / "office1_truth.json").read_text())


def _prior(truth, dx=0.14, dy=0.14, dyaw=5.0) -> str:
    """X,Y,Z,YAW_DEG of the truth camera moved 20 cm and turned 5 degrees."""
    T = np.array(truth["T_world_camera"])
    yaw = math.degrees(math.atan2(T[1, 2], T[0, 2])) + dyaw
    return f"{T[0, 3] + dx},{T[1, 3] + dy},{T[2, 3]},{yaw}"


def _run(ifc, pcd, out, *extra):
    result = runner.invoke(app, ["verify", str(ifc), str(pcd), "--out", str(out), "--json", *extra])
    return result


def _correction(truth) -> str:
    return ",".join(str(g) for g in truth["depth_correction"]["g"])


@pytest.fixture(scope="module")
def corrected(office1_verified):
    """The session's one corrected run (``office1_verified``: the prior of :func:`_prior`, the truth's correction)."""
    assert office1_verified.prior == _prior(office1_verified.truth)
    assert office1_verified.g == _correction(office1_verified.truth)
    return office1_verified.truth, office1_verified.out, office1_verified.summary


def test_verify_localizes_office1_within_3_cm_and_1_degree_of_the_truth(corrected):
    truth, out, _ = corrected
    frame = json.loads((out / "localization.json").read_text())["frames"][0]
    assert frame["accepted"] and frame["source"]
    pose, T_true = np.array(frame["pose"]), np.array(truth["T_world_camera"])
    turned = np.rad2deg(np.arccos(np.clip((np.trace(pose[:3, :3].T @ T_true[:3, :3]) - 1) / 2, -1, 1)))
    assert np.linalg.norm(pose[:3, 3] - T_true[:3, 3]) < 0.03 and turned < 1.0
    assert np.array(frame["covariance"]).shape == (6, 6)


def test_verify_finds_every_furniture_box_of_office1_as_planned(corrected):
    truth, out, summary = corrected
    states = {e["global_id"]: e for e in json.loads((out / "twin.json").read_text())["elements"]}
    for box in truth["furniture"]:
        assert states[box["GlobalId"]]["status"] == "as planned", box["name"]
    # 4 new objects from the unmodelled clutter (truth: unmodelled_clutter); nothing else judged
    assert summary["verdicts"] == {"as planned": len(truth["furniture"]), "deviating": 0, "missing": 0, "new": 4,
                                   "unverified": 0}
    assert not summary["miscalibrated"]
    for name in ("twin.ifc", "issues.bcf", "report.html"):
        assert (out / name).stat().st_size > 0


@pytest.fixture(scope="module")
def edited(sensors, tmp_path_factory):
    """office1.ifc with the desk moved 30 cm along +x and cupboard B deleted, verified."""
    folder = tmp_path_factory.mktemp("edited")
    ifc = ifcopenshell.open(str(sensors / "pcl" / "office1.ifc"))
    desk = ifc.by_guid(MOVED)
    matrix = ifcopenshell.util.placement.get_local_placement(desk.ObjectPlacement)
    matrix[0, 3] += 0.3
    ifcopenshell.api.run("geometry.edit_object_placement", ifc, product=desk, matrix=matrix, is_si=True)
    ifcopenshell.api.run("root.remove_product", ifc, product=ifc.by_guid(DELETED))
    ifc.write(str(folder / "office1_edited.ifc"))
    truth = _truth(sensors)
    result = _run(folder / "office1_edited.ifc", sensors / "pcl" / "office1.pcd", folder / "out", "--prior",
                  _prior(truth), "--depth-correction", _correction(truth))
    assert result.exit_code == 0, result.output
    return truth, folder / "out"


def test_an_edited_ifc_gives_the_moved_box_deviating_by_30_cm_and_the_deleted_one_new(edited):
    truth, out = edited
    states = json.loads((out / "twin.json").read_text())["elements"]
    moved = next(e for e in states if e["global_id"] == MOVED)
    assert moved["status"] == "deviating" and abs(moved["deviation"]["translation"] - 0.30) <= 0.05
    gone = next(b for b in truth["furniture"] if b["GlobalId"] == DELETED)
    new = [e for e in states if e["status"] == "new"
           and np.linalg.norm(np.array(e["pose"])[:2, 3] - gone["centre"][:2]) < 0.5]
    assert new, "no new object where the deleted cupboard stands"
    with zipfile.ZipFile(out / "issues.bcf") as bcf:
        markup = " ".join(bcf.read(n).decode() for n in bcf.namelist() if n.endswith("markup.bcf"))
    assert MOVED in markup and new[0]["global_id"] in markup


def test_without_the_depth_correction_nothing_is_deviating_and_the_sensor_looks_miscalibrated(sensors, tmp_path):
    truth = _truth(sensors)
    result = _run(sensors / "pcl" / "office1.ifc", sensors / "pcl" / "office1.pcd", tmp_path, "--prior",
                  _prior(truth))
    assert result.exit_code == 3, result.output  # refused by the basin: no frame localized
    summary = json.loads(result.output)
    assert summary["localized"] == 0 and "looks miscalibrated" in summary["why"]
    assert summary["miscalibrated"] and "miscalibrated" in summary["warnings"][0]
    assert summary["verdicts"]["deviating"] == 0
    states = json.loads((tmp_path / "twin.json").read_text())["elements"]
    assert not [e for e in states if e["status"] == "deviating"]


def _fails(monkeypatch, capsys, *args) -> str:
    """Run the real entry point (one-line errors, exit codes) with ``args``; its exit code must be 1 and its
    output one line without a traceback: returns that line."""
    from bim2rdt.cli import main

    monkeypatch.setattr(sys, "argv", ["bim2rdt", "verify", *map(str, args)])
    with pytest.raises(SystemExit) as done:
        main()
    captured = capsys.readouterr()
    message = (captured.out + captured.err).strip()
    assert done.value.code == 1, message
    assert "Traceback" not in message and len(message.splitlines()) == 1, message
    return message


@pytest.mark.parametrize("args, message", [
    (["--prior", "1,2"], "--prior needs 4"),
    (["--prior", "100,100,1,0"], "outside the model"),
    (["--up", "0,0,0", "--prior", "1,-4,1.4,80"], "non-zero"),
    (["--up", "0,0,1", "--prior", "1,-4,1.4,80"], "along the optical axis"),
    (["--prior", "1,-4,1.4,80", "--prior-file", "x.json"], "not both"),
    (["--prior", "1,-4,1.4,80", "--depth-correction", "1,2"], "--depth-correction needs 3"),
    (["--own-poses", "map"], "--own-poses must be 'world' or 'odometry'"),
])
def test_bad_verify_options_are_one_line_and_exit_1(sensors, tmp_path, monkeypatch, capsys, args, message):
    line = _fails(monkeypatch, capsys, sensors / "pcl" / "office1.ifc", sensors / "pcl" / "office1.pcd",
                  "--out", tmp_path, *args)
    assert message in line


def test_bad_sources_and_models_are_one_line_and_exit_1(sensors, tmp_path, monkeypatch, capsys):
    ifc, pcd = sensors / "pcl" / "office1.ifc", sensors / "pcl" / "office1.pcd"
    prior = ["--prior", "1.3,-4.5,1.4,82", "--out", tmp_path / "out"]
    assert "no such file" in _fails(monkeypatch, capsys, ifc, tmp_path / "none.pcd", *prior)
    (tmp_path / "empty").mkdir()
    assert "no frames" in _fails(monkeypatch, capsys, ifc, tmp_path / "empty", *prior)
    furniture_only = ifcopenshell.open(str(ifc))
    for global_id in [p.GlobalId for p in furniture_only.by_type("IfcElement") if not p.is_a("IfcFurniture")]:
        try:
            ifcopenshell.api.run("root.remove_product", furniture_only, product=furniture_only.by_guid(global_id))
        except RuntimeError:
            pass  # went with its host (an opening with its wall)
    furniture_only.write(str(tmp_path / "furniture.ifc"))
    assert "no map to localize on" in _fails(monkeypatch, capsys, tmp_path / "furniture.ifc", pcd, *prior)


def test_a_partly_corrected_depth_is_localized_but_every_verdict_is_unverified(sensors, tmp_path):
    truth = _truth(sensors)
    g = ",".join(str(0.7 * x) for x in truth["depth_correction"]["g"])  # 30 % of the bend left in
    result = _run(sensors / "pcl" / "office1.ifc", sensors / "pcl" / "office1.pcd", tmp_path, "--prior",
                  _prior(truth), "--depth-correction", g)
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["localized"] == 1 and summary["miscalibrated"]
    states = [e for e in json.loads((tmp_path / "twin.json").read_text())["elements"]
              if e["status"] != "not observed"]
    assert states and all(e["status"] == "unverified" for e in states)


@pytest.mark.parametrize("suffix", [".ply", ".pcd"])
def test_a_scan_file_goes_the_same_way_as_the_frame(sensors, tmp_path, suffix):
    """office1's corrected points written as a scan (no image: a .ply, or an unorganised .pcd, which is read as a
    scan rather than refused as a frame): localized, the boxes as planned."""
    import pypcd4
    import trimesh

    from bim2rdt.sources import open_source

    truth = _truth(sensors)
    frame = next(iter(open_source(sensors / "pcl" / "office1.pcd", depth_correction=truth["depth_correction"]["g"])))
    valid = frame.valid_depth
    v, u = np.nonzero(valid)
    points = frame.intrinsics.backproject(np.stack([u, v], axis=1).astype(float), frame.depth[valid].astype(float))
    scan = tmp_path / f"office1{suffix}"
    if suffix == ".ply":
        trimesh.PointCloud(points).export(str(scan))
    else:
        pypcd4.PointCloud.from_xyz_points(points.astype(np.float32)).save(scan)
    result = _run(sensors / "pcl" / "office1.ifc", scan, tmp_path / "out", "--prior", _prior(truth))
    assert result.exit_code == 0, result.output
    frame_entry = json.loads((tmp_path / "out" / "localization.json").read_text())["frames"][0]
    assert frame_entry["accepted"] and frame_entry["source"] == scan.name
    states = {e["global_id"]: e["status"] for e in json.loads((tmp_path / "out" / "twin.json").read_text())["elements"]}
    assert all(states[b["GlobalId"]] == "as planned" for b in truth["furniture"])


def test_an_object_the_ifc_puts_where_the_sensor_sees_the_floor_is_missing(sensors, tmp_path):
    """The desk moved 1.5 m into the room in the IFC: its planned place is seen empty (the floor beyond it), and
    the real desk is a new object where it stands."""
    ifc = ifcopenshell.open(str(sensors / "pcl" / "office1.ifc"))
    desk = ifc.by_guid(MOVED)
    matrix = ifcopenshell.util.placement.get_local_placement(desk.ObjectPlacement)
    matrix[0, 3] += 1.5
    matrix[1, 3] -= 1.0
    ifcopenshell.api.run("geometry.edit_object_placement", ifc, product=desk, matrix=matrix, is_si=True)
    ifc.write(str(tmp_path / "moved.ifc"))
    truth = _truth(sensors)
    result = _run(tmp_path / "moved.ifc", sensors / "pcl" / "office1.pcd", tmp_path / "out", "--prior", _prior(truth),
                  "--depth-correction", _correction(truth))
    assert result.exit_code == 0, result.output
    states = json.loads((tmp_path / "out" / "twin.json").read_text())["elements"]
    assert next(e for e in states if e["global_id"] == MOVED)["status"] == "missing"
    desk_truth = next(b for b in truth["furniture"] if b["GlobalId"] == MOVED)
    assert [e for e in states if e["status"] == "new"
            and np.linalg.norm(np.array(e["pose"])[:2, 3] - desk_truth["centre"][:2]) < 0.6]
    assert json.loads((tmp_path / "out" / "localization.json").read_text())["frames"][0]["missing"] == [MOVED]


def test_verify_finds_office1_with_no_prior_within_5_cm_and_2_degrees(sensors, tmp_path):
    """No --prior: the frame is found on the BIM (gravity from the floor), then verified as with a prior."""
    truth = _truth(sensors)
    result = _run(sensors / "pcl" / "office1.ifc", sensors / "pcl" / "office1.pcd", tmp_path / "out",
                  "--depth-correction", "0.0605,0.0071,-0.0041")
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["localized"] == 1
    frame = json.loads((tmp_path / "out" / "localization.json").read_text())["frames"][0]
    assert frame["accepted"] and frame["prior_source"] == "global"
    assert frame["candidates"] and frame["candidates"][0]["gravity"] == "floor"
    pose, T_true = np.array(frame["pose"]), np.array(truth["T_world_camera"])
    turned = np.rad2deg(np.arccos(np.clip((np.trace(pose[:3, :3].T @ T_true[:3, :3]) - 1) / 2, -1, 1)))
    assert np.linalg.norm(pose[:3, 3] - T_true[:3, 3]) < 0.05 and turned < 2.0
    states = {e["global_id"]: e["status"] for e in json.loads((tmp_path / "out" / "twin.json").read_text())["elements"]}
    assert all(states[b["GlobalId"]] == "as planned" for b in truth["furniture"])


def test_verify_refuses_a_storey_the_model_does_not_have_in_one_line(sensors, tmp_path, monkeypatch, capsys):
    line = _fails(monkeypatch, capsys, sensors / "pcl" / "office1.ifc", sensors / "pcl" / "office1.pcd", "--out",
                  tmp_path, "--storey", "Roof")
    assert "no storey 'Roof'" in line and "Office floor" in line
    assert not (tmp_path / "localization.json").exists()
