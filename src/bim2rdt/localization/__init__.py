"""BIM-anchored localization: the robot's camera pose from the permanent structure it sees (walls, columns,
slabs, stairs, door frames), fused with odometry over a tour.

``localize(frame, model, prior_T_world_camera, up)`` fixes one frame and ``localize_cloud`` a point cloud, with one
core (:mod:`.core`); ``PoseFilter`` fuses odometry between stations with those fixes (an EKF over x, y, z and yaw);
``check_shots`` measures each fix against BIM landmarks an engineer can tape. ``OccludedMap`` is the model's
permanent surface with its other bodies as occluders (build it once per model and pass it on), ``scan_points``
thins a cloud as the fix uses it, ``depth_points`` turns a frame's depth into camera-frame points."""

from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.errors import LocalizationError, Refusal
from bim2rdt.localization.filter import OdometryNoise, PoseFilter, StationFix, fuse_frame
from bim2rdt.localization.cloud import (OccludedMap, ScanPoints, localize_cloud, scan_points, sphere_directions,
                                       voxel_means)
from bim2rdt.localization.surfaces import GRAZING_COS
from bim2rdt.localization.depth import depth_points
from bim2rdt.localization.fix import Localization, localize
from bim2rdt.localization.station import Turned, localize_station, pinned

__all__ = ["Localization", "LocalizationConfig", "LocalizationError", "OccludedMap", "OdometryNoise", "PoseFilter",
           "Refusal", "ScanPoints", "StationFix", "Turned", "depth_points", "fuse_frame", "localize", "localize_cloud",
           "localize_station", "pinned", "scan_points", "voxel_means", "GRAZING_COS", "sphere_directions"]
