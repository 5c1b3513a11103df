"""Registration of BIM element models to scene points: Semantic-Gravity ICP (the paper's Algorithm 1) and the
paper's Hausdorff alignment metric. Plain robust ICP is ``register(..., upright_bias=0)``."""

from bim2rdt.registration.config import IcpConfig
from bim2rdt.registration.errors import RegistrationError
from bim2rdt.registration.icp import RegistrationResult, load_kernels, register
from bim2rdt.registration.matching import (SampleTree, any_within, cube_means, nearest_neighbours, neighbour_scatter,
                                           plane_hit_depths, points_in_range, smallest_axes)
from bim2rdt.registration.metrics import HausdorffStats, hausdorff
from bim2rdt.registration.sampling import sample_model
from bim2rdt.registration.so3 import invert_poses
from bim2rdt.registration.symmetry import closest_equivalent
from bim2rdt.registration.uncertainty import POSE_PARAMETERS, PoseUncertainty
from bim2rdt.registration.validation import MIN_SCENE_POINTS, unit_up

__all__ = ["any_within", "closest_equivalent", "cube_means", "hausdorff", "HausdorffStats", "IcpConfig", "invert_poses",
           "load_kernels", "MIN_SCENE_POINTS", "nearest_neighbours", "neighbour_scatter", "plane_hit_depths", "points_in_range",
           "POSE_PARAMETERS",
           "PoseUncertainty", "register", "RegistrationError", "RegistrationResult", "sample_model", "SampleTree",
           "smallest_axes", "unit_up"]
