"""BIM-anchored localization: the robot's camera pose from the permanent structure it sees (walls, columns,
slabs, stairs, door frames), fused with odometry over a tour.

``localize(frame, model, prior_T_world_camera, up)`` fixes one frame; ``PoseFilter`` fuses odometry between
stations with those fixes (an EKF over x, y, z and yaw); ``check_shots`` measures each fix against BIM landmarks
an engineer can tape; ``find_pose(data, model)`` finds the sensor on the BIM without a prior (candidates, and
``choose`` says whether one is to be taken or the view is ambiguous)."""

from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.errors import LocalizationError
from bim2rdt.localization.filter import OdometryNoise, PoseFilter, StationFix, fuse_frame
from bim2rdt.localization.cloud import localize_cloud
from bim2rdt.localization.fix import Localization, localize
from bim2rdt.localization.global_config import GlobalSearchConfig
from bim2rdt.localization.global_search import Candidate, choose, find_pose
from bim2rdt.localization.station import Turned, localize_station, pinned

__all__ = ["Candidate", "GlobalSearchConfig", "Localization", "LocalizationConfig", "LocalizationError",
           "OdometryNoise", "PoseFilter", "StationFix", "Turned", "choose", "find_pose", "fuse_frame", "localize",
           "localize_cloud", "localize_station", "pinned"]
