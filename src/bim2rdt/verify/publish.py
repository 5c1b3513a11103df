"""The results as a ROS 2 bag for the robot's own stack (``verify --publish results.mcap``, ``demo --publish``):

- ``/tf``: ``map -> odom`` per localized frame: the BIM fix times the inverse of the frame's recorded pose, i.e.
  what the recording's world frame (``odom``, or ``map`` with its map -> odom) should have been in ``map``;
- ``/bim2rdt/pose`` (``geometry_msgs/PoseWithCovarianceStamped``, ``map``): the fixed camera pose and its 6x6
  covariance in ROS order (x, y, z, rot x, rot y, rot z); the library's covariance is over (dx, dy, dz,
  dtheta_x, dtheta_y, dtheta_z) in the world frame, the same order (``ROS_ORDER`` is the identity, kept named);
- ``/bim2rdt/objects`` (``visualization_msgs/MarkerArray``, ``map``): one marker per element of the twin at its
  pose (measured, else the BIM's), its body mesh as a TRIANGLE_LIST (a CUBE of its box above ``MAX_TRIANGLES``),
  coloured by status (:data:`STATUS_RGBA`);
- ``/map`` and ``/keepout_filter_mask`` (``nav_msgs/OccupancyGrid``, latched at the first stamp): the grids
  :meth:`~bim2rdt.planning.OccupancyGrid.save_nav2` writes as PGM (occupied 100, free 0).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.perception import ElementStatus
from bim2rdt.sources import BagWriter
from bim2rdt.sources import translation_quaternion

ROS_ORDER = [0, 1, 2, 3, 4, 5]
"""ROS covariance index i <- the library's index ROS_ORDER[i] (both x, y, z, rot x, rot y, rot z)."""
MAX_TRIANGLES = 20_000
STATUS_RGBA = {ElementStatus.AS_PLANNED: (0.2, 0.8, 0.2, 0.8), ElementStatus.DEVIATING: (1.0, 0.55, 0.0, 0.9),
               ElementStatus.MISSING: (0.9, 0.1, 0.1, 0.6), ElementStatus.NEW: (0.2, 0.4, 1.0, 0.9),
               ElementStatus.UNVERIFIED: (0.6, 0.6, 0.6, 0.8), ElementStatus.NOT_OBSERVED: (0.8, 0.8, 0.8, 0.3),
               ElementStatus.NOT_BUILT: (0.55, 0.34, 0.29, 0.6)}


def ros_covariance(covariance: np.ndarray) -> np.ndarray:
    """The library's 6x6 pose covariance as ROS's row-major 36 floats."""
    C = np.asarray(covariance, float)
    return C[np.ix_(ROS_ORDER, ROS_ORDER)].reshape(-1)


def publish_results(path, frames: Sequence, states: dict, model: BimModel, grid=None) -> Path:
    """Write the bag at ``path`` (see the module's note). ``frames``: anything with ``time``, ``accepted``,
    ``pose``, ``covariance`` and ``recorded`` (the frame's own pose, or None); ``states``: the twin's
    ``state()``; ``grid``: an :class:`~bim2rdt.planning.OccupancyGrid` (None: no map topics). Returns the bag
    folder."""
    times = [f.time for f in frames if f.time is not None]
    start = min(times) if times else 0.0
    with BagWriter(path) as bag:
        if grid is not None:
            _grids(bag, grid, start)
        for index, frame in enumerate(frames):
            if not frame.accepted:
                continue
            when = frame.time if frame.time is not None else start + index
            if frame.recorded is not None:
                bag.write_tf([("map", "odom", frame.pose @ np.linalg.inv(frame.recorded))], when)
            bag.write("/bim2rdt/pose", _pose(bag, frame.pose, frame.covariance, when), when)
        bag.write("/bim2rdt/objects", _markers(bag, states, model, max(times) if times else start),
                  max(times) if times else start)
    return bag.folder


def _pose(bag: BagWriter, T: np.ndarray, covariance: np.ndarray, when: float):
    types = bag.types
    return types["geometry_msgs/msg/PoseWithCovarianceStamped"](
        header=bag.header("map", when), pose=types["geometry_msgs/msg/PoseWithCovariance"](
            pose=_geometry_pose(bag, T), covariance=ros_covariance(covariance)))


def _geometry_pose(bag: BagWriter, T: np.ndarray):
    types = bag.types
    t, q = translation_quaternion(T)
    return types["geometry_msgs/msg/Pose"](position=types["geometry_msgs/msg/Point"](x=t[0], y=t[1], z=t[2]),
                                           orientation=types["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2],
                                                                                             w=q[3]))


def element_pose(state, model: BimModel) -> np.ndarray:
    """The twin's pose of an element: measured, else the BIM's placement."""
    if state.pose is not None:
        return np.asarray(state.pose, float)
    return np.asarray(model.element(state.global_id).placement, float)


def _markers(bag: BagWriter, states: dict, model: BimModel, when: float):
    types = bag.types
    markers = []
    for number, (global_id, state) in enumerate(sorted(states.items())):
        T = element_pose(state, model)
        vertices, faces = _local_mesh(state, model, T)
        if len(vertices) == 0:
            continue
        r, g, b, a = STATUS_RGBA.get(ElementStatus(state.status), (1.0, 1.0, 1.0, 0.5))
        marker = dict(header=bag.header("map", when), ns=f"bim2rdt/{ElementStatus(state.status).value}", id=number,
                      action=0, pose=_geometry_pose(bag, T), color=types["std_msgs/msg/ColorRGBA"](r=r, g=g, b=b, a=a),
                      lifetime=types["builtin_interfaces/msg/Duration"](sec=0, nanosec=0), frame_locked=False,
                      text=global_id, mesh_resource="", mesh_use_embedded_materials=False, colors=[],
                      texture_resource="", texture=types["sensor_msgs/msg/CompressedImage"](
                          header=bag.header("", when), format="", data=np.zeros(0, np.uint8)), uv_coordinates=[],
                      mesh_file=types["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)))
        if len(faces) <= MAX_TRIANGLES:
            corners = vertices[np.asarray(faces).reshape(-1)]
            marker.update(type=11, scale=types["geometry_msgs/msg/Vector3"](x=1.0, y=1.0, z=1.0),
                          points=[types["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]) for p in corners])
        else:
            low, high = vertices.min(axis=0), vertices.max(axis=0)
            size, centre = high - low, (high + low) / 2
            box = T @ np.r_[centre, 1.0]
            marker.update(type=1, scale=types["geometry_msgs/msg/Vector3"](x=size[0], y=size[1], z=size[2]),
                          points=[])
            marker["pose"] = _geometry_pose(bag, np.block([[T[:3, :3], box[:3, None]], [np.zeros((1, 3)), 1.0]]))
        markers.append(_marker(types, marker))
    return types["visualization_msgs/msg/MarkerArray"](markers=markers)


def _marker(types, fields: dict):
    Marker = types["visualization_msgs/msg/Marker"]
    return Marker(**{name: fields[name] for name in Marker.__dataclass_fields__
                     if not name.isupper() and not name.startswith("__")})


def _local_mesh(state, model: BimModel, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The element's body mesh in its own frame: the twin's mesh of a new object, else the BIM's."""
    if state.mesh is not None:
        return np.asarray(state.mesh[0], float), np.asarray(state.mesh[1])
    if not model.has_mesh(state.global_id):
        return np.zeros((0, 3)), np.zeros((0, 3), int)
    vertices_world, faces = model.mesh(state.global_id)
    placement = np.asarray(model.element(state.global_id).placement, float)
    return (vertices_world - placement[:3, 3]) @ placement[:3, :3], faces


def _grids(bag: BagWriter, grid, when: float) -> None:
    from bim2rdt.planning import KEEPOUT_KINDS, STRUCTURE_KINDS

    bag.write("/map", occupancy_message(bag, grid, grid.layer(STRUCTURE_KINDS + ("object",)), when), when)
    keepout = grid.layer(KEEPOUT_KINDS)
    if keepout.any():
        bag.write("/keepout_filter_mask", occupancy_message(bag, grid, keepout, when), when)


def occupancy_message(bag: BagWriter, grid, occupied: np.ndarray, when: float):
    """A ``nav_msgs/OccupancyGrid``: row 0 at the grid's origin (its lower-left corner), 100 occupied, 0 free."""
    types = bag.types
    rows, cols = occupied.shape
    x0, y0 = grid.frame.origin_xy
    origin = np.eye(4)
    origin[:3, 3] = (x0, y0, 0.0)
    sec = int(np.floor(when))
    return types["nav_msgs/msg/OccupancyGrid"](
        header=bag.header("map", when), info=types["nav_msgs/msg/MapMetaData"](
            map_load_time=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=0), resolution=float(grid.resolution),
            width=cols, height=rows, origin=_geometry_pose(bag, origin)),
        data=np.where(occupied, 100, 0).astype(np.int8).reshape(-1))
