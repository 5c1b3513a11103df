"""verify --publish: every topic of the results bag read back with rosbags: frames, the covariance in ROS order,
a marker at the twin's pose, and the grids equal to the PGMs save_nav2 writes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from results_bag import check_fixes, check_grid, check_markers, messages
from typer.testing import CliRunner

from bim2rdt.cli import app
from bim2rdt.planning import KeepOut, OccupancyGrid
from bim2rdt.sources import open_source
from bim2rdt.verify import prior_pose
from bim2rdt.verify.publish import publish_results, ros_covariance
from tests.cli.test_verify_bag import _bag_of

runner = CliRunner()


@pytest.fixture(scope="module")
def published(sensors, tmp_path_factory):
    folder = tmp_path_factory.mktemp("publish")
    truth = json.loads((sensors / "pcl" / "office1_truth.json").read_text())
    T = np.array(truth["T_world_camera"])
    yaw = np.degrees(np.arctan2(T[1, 2], T[0, 2])) + 5.0
    frame = next(iter(open_source(sensors / "pcl" / "office1.pcd")))
    _bag_of(frame, folder / "office1.mcap", prior_pose((T[0, 3] + 0.14, T[1, 3] + 0.14, T[2, 3]), yaw, None))
    g = ",".join(str(v) for v in truth["depth_correction"]["g"])
    result = runner.invoke(app, ["verify", str(sensors / "pcl" / "office1.ifc"), str(folder / "office1"), "--out",
                                 str(folder / "out"), "--json", "--depth-correction", g, "--publish",
                                 str(folder / "results.mcap")])
    assert result.exit_code == 0, result.output
    return folder, messages(folder / "results")


def test_the_fix_is_published_as_map_to_odom_and_the_pose_in_map_with_its_covariance(published):
    folder, topics = published
    entry = json.loads((folder / "out" / "localization.json").read_text())["frames"][0]
    # the bag's own pose was the first prior; the bag's one frame has its time
    check_fixes(topics, [(entry["time"], np.array(entry["pose"]), np.array(entry["covariance"]),
                          np.array(entry["prior"]))])


def test_the_covariance_goes_out_in_ros_order():
    C = np.diag([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])  # dx, dy, dz, dtheta_x, dtheta_y, dtheta_z (docs: architecture)
    C[0, 5] = C[5, 0] = 0.5  # x with yaw
    ros = ros_covariance(C).reshape(6, 6)
    assert np.diag(ros).tolist() == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0] and ros[0, 5] == 0.5 and ros[5, 0] == 0.5


def test_each_element_is_a_marker_at_the_twins_pose_coloured_by_status(published):
    folder, topics = published
    twin = json.loads((folder / "out" / "twin.json").read_text())
    check_markers(topics, {e["global_id"]: e for e in twin["elements"]})


def test_the_map_equals_the_pgm_save_nav2_writes(published):
    folder, topics = published
    check_grid(topics, "/map", folder / "out" / "maps" / "site.pgm")


def test_a_keepout_zone_is_published_as_the_filter_mask_equal_to_its_pgm(tmp_path, office1):
    model = office1.model
    grid = OccupancyGrid.from_bim(model)
    centre = grid.frame.origin_xy[0] + 1.0, grid.frame.origin_xy[1] + 1.0
    grid = grid.with_zones([KeepOut.circle("crane", centre, 0.5)])
    written = grid.save_nav2(tmp_path, "site")
    publish_results(tmp_path / "out.mcap", [], {}, model, grid)
    check_grid(messages(tmp_path / "out"), "/keepout_filter_mask", written["keepout_image"])
