"""Reading a results bag (``verify --publish``, ``demo --publish``) back with rosbags, and the checks both
commands' tests share: the fixes as ``map -> odom`` and ``/bim2rdt/pose`` with the covariance in ROS order, a
marker per element at the twin's pose coloured by status, and the grids equal to the Nav2 PGMs."""

from __future__ import annotations

import numpy as np
from nav2_maps import read_pgm
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation


def messages(folder) -> dict:
    """Every message of the bag folder, by topic, in order."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    topics: dict = {}
    with AnyReader([folder], default_typestore=store) as reader:
        for connection, _, raw in reader.messages():
            topics.setdefault(connection.topic, []).append(reader.deserialize(raw, connection.msgtype))
    return topics


def matrix(pose) -> np.ndarray:
    """A ``geometry_msgs/Pose`` (or anything with ``position`` and ``orientation``) as a 4x4."""
    T = np.eye(4)
    q = pose.orientation
    T[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    T[:3, 3] = (pose.position.x, pose.position.y, pose.position.z)
    return T


def transform_matrix(transform) -> np.ndarray:
    """A ``geometry_msgs/Transform`` as a 4x4."""
    return matrix(type("P", (), {"position": transform.translation, "orientation": transform.rotation}))


def grid_of(message) -> np.ndarray:
    return np.asarray(message.data).reshape(message.info.height, message.info.width)


def stamp(header) -> float:
    return header.stamp.sec + 1e-9 * header.stamp.nanosec


def check_fixes(topics: dict, fixes: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]]) -> None:
    """``fixes``: each accepted frame's (time, fixed T_map_camera, covariance (6, 6), recorded T_odom_camera):
    one ``map -> odom`` per fix that carries the recorded pose onto the fix, and one ``/bim2rdt/pose`` in
    ``map`` with the covariance in ROS order (x, y, z, rot x, rot y, rot z: the library's own)."""
    transforms = [t for message in topics["/tf"] for t in message.transforms]
    poses = topics["/bim2rdt/pose"]
    assert len(transforms) == len(poses) == len(fixes) > 0
    for transform, pose, (when, fix, covariance, recorded) in zip(transforms, poses, fixes):
        assert (transform.header.frame_id, transform.child_frame_id) == ("map", "odom")
        assert abs(stamp(transform.header) - when) < 1e-6 and abs(stamp(pose.header) - when) < 1e-6
        assert np.allclose(transform_matrix(transform.transform) @ recorded, fix, atol=1e-6)
        assert pose.header.frame_id == "map" and np.allclose(matrix(pose.pose.pose), fix, atol=1e-6)
        assert np.allclose(np.asarray(pose.pose.covariance).reshape(6, 6), covariance)


def check_markers(topics: dict, elements: dict) -> None:
    """One marker per element of the twin (``elements``: twin.json's, by GlobalId) in ``map``, at the twin's
    pose, in its status' namespace, one colour per status."""
    (array,) = topics["/bim2rdt/objects"]
    markers = {m.text: m for m in array.markers}
    assert markers and set(markers) <= set(elements)
    observed = [gid for gid, e in elements.items() if e.get("pose") is not None and gid in markers]
    assert observed
    for gid in observed:
        assert markers[gid].header.frame_id == "map"
        assert np.allclose(matrix(markers[gid].pose), np.array(elements[gid]["pose"]), atol=1e-6)
        assert markers[gid].ns == f"bim2rdt/{elements[gid]['status']}"
    statuses = {m.ns: (m.color.r, m.color.g, m.color.b) for m in array.markers}
    assert len(set(statuses.values())) == len(statuses)


def check_grid(topics: dict, topic: str, pgm_path) -> None:
    """The ``topic``'s one OccupancyGrid, in ``map``, occupied exactly where the PGM is dark (its first row is
    the top; the grid's row 0 is at its origin)."""
    (grid,) = topics[topic]
    pgm = read_pgm(pgm_path)[::-1]
    assert grid.header.frame_id == "map" and grid_of(grid).shape == pgm.shape
    assert (grid_of(grid) == 100).any() and np.array_equal(grid_of(grid) == 100, pgm < 128)
