"""What the user of `bim2rdt verify` is told (issue 31, section 6): a run in which no frame localized exits 3 and
says why, with a hint at the prior; a fix with a free direction is partial, with the direction; a millimetre scan
and a camera without intrinsics verify with --depth-scale and --intrinsics, and the errors name them; an unknown
extension lists every reader. On the real office1 frame."""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

from bim2rdt.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def office(sensors):
    truth = json.loads((sensors / "pcl" / "office1_truth.json").read_text())
    T = np.array(truth["T_world_camera"])
    return {"ifc": sensors / "pcl" / "office1.ifc", "pcd": sensors / "pcl" / "office1.pcd", "T": T,
            "yaw": math.degrees(math.atan2(T[1, 2], T[0, 2])), "g": ",".join(map(str, truth["depth_correction"]["g"]))}


def _run(*args):
    return runner.invoke(app, ["verify", *map(str, args), "--json"])


def _prior(office, z=None, yaw=None) -> str:
    T = office["T"]
    return f"{T[0, 3] + 0.1},{T[1, 3] + 0.1},{T[2, 3] if z is None else z},{office['yaw'] if yaw is None else yaw}"


def test_a_yaw_given_in_radians_localizes_no_frame_exits_3_and_hints_at_the_prior(office, tmp_path):
    radians = math.radians(office["yaw"])
    result = _run(office["ifc"], office["pcd"], "--out", tmp_path, "--prior", _prior(office, yaw=radians),
                  "--depth-correction", office["g"])
    assert result.exit_code == 3, result.output
    summary = json.loads(result.output)
    assert summary["localized"] == 0 and summary["why"].startswith("no frame localized (1 sees no permanent element)")
    assert f"heads it {radians:.0f} deg from +x" in summary["why"] and "not radians" in summary["why"]
    frame = json.loads((tmp_path / "localization.json").read_text())["frames"][0]
    assert frame["fix"] == "refused" and frame["refusal"] == "sees no permanent element"
    assert (tmp_path / "twin.json").is_file() and (tmp_path / "config.json").is_file()  # outputs still written


def test_a_prior_at_floor_height_is_hinted_whatever_the_refusal(office, tmp_path):
    result = _run(office["ifc"], office["pcd"], "--out", tmp_path, "--prior", _prior(office, z=0.02),
                  "--depth-correction", office["g"])
    assert result.exit_code == 3, result.output
    why = json.loads(result.output)["why"]
    assert "check the prior: it puts the sensor 0.02 m above the floor under it" in why


def test_no_frame_localized_is_documented_in_the_help():
    result = runner.invoke(app, ["verify", "--help"], terminal_width=200)
    assert result.exit_code == 0 and "3 when no frame was localized" in " ".join(result.output.split())


def test_a_localized_frame_is_a_full_fix_and_exits_0(office, tmp_path):
    result = _run(office["ifc"], office["pcd"], "--out", tmp_path, "--prior", _prior(office),
                  "--depth-correction", office["g"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["localized"] == 1 and summary["partial"] == 0 and "why" not in summary
    frame = json.loads((tmp_path / "localization.json").read_text())["frames"][0]
    assert frame["fix"] == "full" and frame["free"] == []


def test_a_fix_with_a_free_direction_is_partial_and_says_which():
    from bim2rdt.cli.verify import _fix_label
    from bim2rdt.verify.chain import FrameResult, free_directions

    assert free_directions([np.array([1.0, 0, 0]), np.array([0, 0.02, -0.9998])], yaw=True) == [
        "x free", "z free", "yaw free"]
    along = np.array([np.cos(np.radians(30)), np.sin(np.radians(30)), 0.0])
    assert free_directions([along]) == free_directions([-along]) == ["free along 30 deg"]
    frame = FrameResult(0, "f", None, np.eye(4), pose=np.eye(4), accepted=True, degenerate=[np.array([0, 1.0, 0])])
    assert frame.fix == "partial" and frame.to_dict()["free"] == ["y free"] and frame.to_dict()["fix"] == "partial"
    assert _fix_label(frame) == "partial (y free)"
    assert FrameResult(0, "f", None, None).fix == "refused"


def _office_points(office):
    from bim2rdt.localization import depth_points
    from bim2rdt.sources import open_source

    [frame] = list(open_source(office["pcd"], depth_correction=[float(x) for x in office["g"].split(",")]))
    return frame, depth_points(frame)


def test_a_millimetre_scan_verifies_with_depth_scale_and_the_error_names_it(office, tmp_path):
    import pypcd4

    _, points = _office_points(office)
    pypcd4.PointCloud.from_xyz_points((points * 1000).astype(np.float32)).save(tmp_path / "mm.pcd")
    refused = _run(office["ifc"], tmp_path / "mm.pcd", "--out", tmp_path / "a", "--prior", _prior(office))
    assert refused.exit_code == 1 and "verify --depth-scale 1000" in str(refused.exception)
    result = _run(office["ifc"], tmp_path / "mm.pcd", "--out", tmp_path / "b", "--prior", _prior(office),
                  "--depth-scale", "1000")
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["localized"] == 1


def test_a_png_pair_without_intrinsics_verifies_with_intrinsics_and_the_error_names_it(office, tmp_path):
    import cv2

    frame, _ = _office_points(office)
    pair = tmp_path / "pair"
    pair.mkdir()
    depth_mm = np.where(np.isfinite(frame.depth), np.round(frame.depth * 1000), 0).astype(np.uint16)
    cv2.imwrite(str(pair / "office_depth.png"), depth_mm)
    cv2.imwrite(str(pair / "office_color.png"), frame.rgb[..., ::-1])
    refused = _run(office["ifc"], pair, "--out", tmp_path / "a", "--prior", _prior(office), "--depth-scale", "1000")
    assert refused.exit_code == 1 and "verify --intrinsics" in str(refused.exception)
    k = frame.intrinsics
    (tmp_path / "k.json").write_text(json.dumps({"fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy}))
    result = _run(office["ifc"], pair, "--out", tmp_path / "b", "--prior", _prior(office), "--depth-scale", "1000",
                  "--intrinsics", tmp_path / "k.json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["localized"] == 1


def _fails(monkeypatch, capsys, *args) -> str:
    from bim2rdt.cli import main

    monkeypatch.setattr(sys, "argv", ["bim2rdt", "verify", *map(str, args)])
    with pytest.raises(SystemExit) as done:
        main()
    message = "".join(capsys.readouterr()).strip()
    assert done.value.code == 1 and len(message.splitlines()) == 1, message
    return message


def test_bad_depth_scale_intrinsics_and_extensions_are_one_line(office, tmp_path, monkeypatch, capsys):
    args = [office["ifc"], office["pcd"], "--out", tmp_path / "o", "--prior", _prior(office)]
    assert "--depth-scale must be a positive number" in _fails(monkeypatch, capsys, *args, "--depth-scale", "-5")
    (tmp_path / "bad.json").write_text('{"fx": 500}')
    assert "--intrinsics" in _fails(monkeypatch, capsys, *args, "--intrinsics", tmp_path / "bad.json")
    (tmp_path / "notes.txt").write_text("x")
    line = _fails(monkeypatch, capsys, office["ifc"], tmp_path / "notes.txt", "--out", tmp_path / "o", "--prior",
                  _prior(office))
    for suffix in (".pcd", ".mkv", ".mcap", ".db3", ".bag", ".ply", ".las", ".laz", ".e57"):
        assert suffix in line, suffix
