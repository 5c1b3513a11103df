"""Real frames as a ROS bag: office1's Kinect frame written as a RealSense-style bag (static TF at a prior 20 cm and
5 degrees off) verifies exactly as the frame itself with that prior; the TUM frame reads back unchanged."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from bim2rdt.cli import app
from bim2rdt.sources import open_source
from bim2rdt.sources.bag_writer import BagWriter
from bim2rdt.verify import prior_pose
from tests.sources.bags import CAMERA, COLOUR, DEPTH, INFO

runner = CliRunner()


def _bag_of(frame, path, T_map_camera=None):
    with BagWriter(path) as bag:
        if T_map_camera is not None:
            bag.write_tf([("map", "base_link", T_map_camera), ("base_link", CAMERA, np.eye(4))], 0.0, static=True)
        bag.write_camera_info(INFO, CAMERA, 5.0, frame.intrinsics)
        bag.write_colour(COLOUR, CAMERA, 5.0, frame.rgb)
        bag.write_depth(DEPTH, CAMERA, 5.0, frame.depth)


def _verify(ifc, source, out, *extra):
    result = runner.invoke(app, ["verify", str(ifc), str(source), "--out", str(out), "--json", *extra])
    assert result.exit_code == 0, result.output
    return json.loads((out / "localization.json").read_text())["frames"], json.loads((out / "twin.json").read_text())


def _statuses(twin) -> dict:
    elements = twin["elements"] if isinstance(twin, dict) and "elements" in twin else twin
    return {e["global_id"]: e["status"] for e in elements}


def test_office1_as_a_bag_verifies_as_the_frame_does(sensors, tmp_path, office1_verified):
    truth, g = office1_verified.truth, office1_verified.g  # the frame: the session's run, from the same prior
    T = np.array(truth["T_world_camera"])
    yaw = np.degrees(np.arctan2(T[1, 2], T[0, 2])) + 5.0
    assert office1_verified.prior == f"{T[0, 3] + 0.14},{T[1, 3] + 0.14},{T[2, 3]},{yaw}"
    frame = next(iter(open_source(sensors / "pcl" / "office1.pcd")))
    _bag_of(frame, tmp_path / "office1.mcap", prior_pose((T[0, 3] + 0.14, T[1, 3] + 0.14, T[2, 3]), yaw, None))
    ifc = sensors / "pcl" / "office1.ifc"
    out = office1_verified.out
    direct = json.loads((out / "localization.json").read_text())["frames"], json.loads((out / "twin.json").read_text())
    bagged = _verify(ifc, tmp_path / "office1", tmp_path / "bag", "--depth-correction", g)
    assert bagged[0][0]["accepted"] and direct[0][0]["accepted"]
    assert np.allclose(bagged[0][0]["pose"], direct[0][0]["pose"], atol=2e-3)  # millimetre depth in the bag
    bag_status, direct_status = _statuses(bagged[1]), _statuses(direct[1])
    planned = {gid: status for gid, status in direct_status.items() if status != "new"}
    assert planned and {gid: bag_status.get(gid) for gid in planned} == planned
    assert sorted(bag_status.values()) == sorted(direct_status.values())  # new objects get fresh GlobalIds
    assert bagged[0][0]["source"].startswith(DEPTH)


def test_the_tum_frame_as_a_bag_reads_back_unchanged(sensors, tmp_path):
    frame = next(iter(open_source(sensors / "tum")))
    _bag_of(frame, tmp_path / "tum.mcap", np.eye(4))
    bagged = next(iter(open_source(tmp_path / "tum")))
    assert np.array_equal(bagged.rgb, frame.rgb) and bagged.intrinsics == frame.intrinsics
    valid = frame.depth > 0
    assert np.array_equal(bagged.depth > 0, valid)
    assert np.abs(bagged.depth[valid] - frame.depth[valid]).max() <= 5e-4 + 1e-6  # TUM's 0.2 mm steps in mm
