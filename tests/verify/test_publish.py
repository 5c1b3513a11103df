"""verify --publish: every topic of the results bag read back with rosbags: frames, the covariance in ROS order,
a marker at the twin's pose, and the grids equal to the PGMs save_nav2 writes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from bim2rdt.cli import app
from bim2rdt.planning import KeepOut, OccupancyGrid
from nav2_maps import read_pgm
from bim2rdt.sources import open_source
from bim2rdt.verify import prior_pose
from bim2rdt.verify.publish import publish_results, ros_covariance
from tests.cli.test_verify_bag import _bag_of

runner = CliRunner()


def _messages(folder) -> dict:
    store = get_typestore(Stores.ROS2_HUMBLE)
    topics: dict = {}
    with AnyReader([folder], default_typestore=store) as reader:
        for connection, _, raw in reader.messages():
            topics.setdefault(connection.topic, []).append(reader.deserialize(raw, connection.msgtype))
    return topics


def _matrix(pose) -> np.ndarray:
    T = np.eye(4)
    q = pose.orientation
    T[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    T[:3, 3] = (pose.position.x, pose.position.y, pose.position.z)
    return T


def _grid_of(message) -> np.ndarray:
    return np.asarray(message.data).reshape(message.info.height, message.info.width)


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
    return folder, _messages(folder / "results")


def test_the_fix_is_published_as_map_to_odom_and_the_pose_in_map_with_its_covariance(published):
    folder, topics = published
    entry = json.loads((folder / "out" / "localization.json").read_text())["frames"][0]
    fix = np.array(entry["pose"])
    (tf,) = topics["/tf"]
    (transform,) = tf.transforms
    assert (transform.header.frame_id, transform.child_frame_id) == ("map", "odom")
    recorded = np.array(entry["prior"])  # the bag's own pose was the first prior
    t = transform.transform
    T_map_odom = _matrix(type("P", (), {"position": t.translation, "orientation": t.rotation}))
    assert np.allclose(T_map_odom @ recorded, fix, atol=1e-6)
    (pose,) = topics["/bim2rdt/pose"]
    assert pose.header.frame_id == "map" and np.allclose(_matrix(pose.pose.pose), fix, atol=1e-6)
    assert np.allclose(np.asarray(pose.pose.covariance).reshape(6, 6), np.array(entry["covariance"]))


def test_the_covariance_goes_out_in_ros_order():
    C = np.diag([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])  # dx, dy, dz, dtheta_x, dtheta_y, dtheta_z (DESIGN.md)
    C[0, 5] = C[5, 0] = 0.5  # x with yaw
    ros = ros_covariance(C).reshape(6, 6)
    assert np.diag(ros).tolist() == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0] and ros[0, 5] == 0.5 and ros[5, 0] == 0.5


def test_each_element_is_a_marker_at_the_twins_pose_coloured_by_status(published):
    folder, topics = published
    twin = json.loads((folder / "out" / "twin.json").read_text())
    elements = {e["global_id"]: e for e in (twin["elements"] if isinstance(twin, dict) else twin)}
    (array,) = topics["/bim2rdt/objects"]
    markers = {m.text: m for m in array.markers}
    assert markers and set(markers) <= set(elements)
    observed = [gid for gid, e in elements.items() if e.get("pose") is not None and gid in markers]
    assert observed
    for gid in observed:
        assert markers[gid].header.frame_id == "map"
        assert np.allclose(_matrix(markers[gid].pose), np.array(elements[gid]["pose"]), atol=1e-6)
        assert markers[gid].ns == f"bim2rdt/{elements[gid]['status']}"
    statuses = {m.ns: (m.color.r, m.color.g, m.color.b) for m in array.markers}
    assert len(set(statuses.values())) == len(statuses)  # one colour per status


def test_the_map_equals_the_pgm_save_nav2_writes(published):
    folder, topics = published
    (grid,) = topics["/map"]
    pgm = read_pgm(folder / "out" / "maps" / "site.pgm")[::-1]  # PGM's first row is the top
    assert grid.header.frame_id == "map" and _grid_of(grid).shape == pgm.shape
    assert np.array_equal(_grid_of(grid) == 100, pgm < 128)


def test_a_keepout_zone_is_published_as_the_filter_mask_equal_to_its_pgm(tmp_path, office1):
    model = office1.model
    grid = OccupancyGrid.from_bim(model)
    centre = grid.frame.origin_xy[0] + 1.0, grid.frame.origin_xy[1] + 1.0
    grid = grid.with_zones([KeepOut.circle("crane", centre, 0.5)])
    written = grid.save_nav2(tmp_path, "site")
    publish_results(tmp_path / "out.mcap", [], {}, model, grid)
    (mask,) = _messages(tmp_path / "out")["/keepout_filter_mask"]
    pgm = read_pgm(written["keepout_image"])[::-1]
    assert (_grid_of(mask) == 100).any() and np.array_equal(_grid_of(mask) == 100, pgm < 128)
