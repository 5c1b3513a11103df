"""BIM-anchored localization: the robot's camera pose from the permanent structure it sees (walls, columns,
slabs, stairs, door frames), fused with odometry over a tour.

``localize(frame, model, prior_T_world_camera, up)`` fixes one frame and ``localize_cloud`` a point cloud, with one
core (:mod:`.core`); ``PoseFilter`` fuses odometry between stations with those fixes (an EKF over x, y, z and yaw);
``check_shots`` measures each fix against BIM landmarks an engineer can tape. ``OccludedMap`` is the model's
permanent surface with its other bodies as occluders (build it once per model and pass it on), ``scan_points``
thins a cloud as the fix uses it, ``depth_points`` turns a frame's depth into camera-frame points;
``find_pose(data, model)`` finds the sensor on the BIM without a prior (candidates, and ``choose`` says whether one
is to be taken or the view is ambiguous); ``Sweep`` carries an ambiguous view's places through a sequence by
odometry until one is left (``carry`` one step, ``refix`` a held frame from its back-filled pose)."""

from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.errors import LocalizationError, Refusal
from bim2rdt.localization.filter import OdometryNoise, PoseFilter, StationFix, fuse_frame
from bim2rdt.localization.cloud import (OccludedMap, ScanPoints, load_lattices, localize_cloud, scan_points,
                                       sphere_directions, voxel_means)
from bim2rdt.localization.surfaces import GRAZING_COS
from bim2rdt.localization.depth import depth_points
from bim2rdt.localization.odometry import icp_odometry
from bim2rdt.localization.fix import Localization, localize
from bim2rdt.localization.global_config import GlobalSearchConfig
from bim2rdt.localization.global_search import Candidate, choose, find_pose
from bim2rdt.localization.hypotheses import Sweep, SweepStep, carry, refix
from bim2rdt.localization.checkshots import StationCheck, check_shots
from bim2rdt.localization.planar import between, from_planar, to_planar
from bim2rdt.localization.station import Turned, localize_station, pinned

__all__ = ["between", "Candidate", "carry", "check_shots", "choose", "depth_points", "find_pose", "from_planar",
           "fuse_frame", "GlobalSearchConfig", "GRAZING_COS", "icp_odometry", "Localization", "LocalizationConfig",
           "LocalizationError", "load_lattices", "localize", "localize_cloud", "localize_station", "OccludedMap",
           "OdometryNoise", "pinned", "PoseFilter", "Refusal", "refix", "scan_points", "ScanPoints",
           "sphere_directions", "StationCheck", "StationFix", "Sweep", "SweepStep", "to_planar", "Turned", "voxel_means"]
