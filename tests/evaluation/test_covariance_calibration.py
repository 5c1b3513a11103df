"""The covariance check: the true error in the covariance's parameters, judged against its 95 % ellipsoid."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from bim2rdt.evaluation.calibration import CovarianceCheck, calibration, check_covariance, pose_error_vector
from bim2rdt.registration.so3 import axis_angle

MODEL = np.array([[x, y, z] for x in (-0.2, 0.4) for y in (-0.1, 0.3) for z in (0.0, 0.5)])


def _moved(rotation_vector, shift):
    """A pose that turns the model about its centroid by ``rotation_vector`` and then shifts it."""
    R = axis_angle(np.asarray(rotation_vector) / max(np.linalg.norm(rotation_vector), 1e-12),
                   np.array(np.linalg.norm(rotation_vector)))
    centroid = MODEL.mean(axis=0)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, centroid - R @ centroid + np.asarray(shift)
    return T


def test_the_error_vector_is_the_rotation_about_the_centroid_then_the_centroid_shift():
    truth = _moved([0.0, 0.0, 0.02], [0.01, -0.02, 0.005])
    error = pose_error_vector("none", np.eye(4), truth, MODEL, order=1)
    assert np.allclose(error, [0.0, 0.0, 0.02, 0.01, -0.02, 0.005], atol=1e-9)


def test_an_error_inside_the_ellipsoid_passes_and_one_far_outside_does_not():
    covariance = np.diag([1e-4] * 3 + [1e-6] * 3)  # 10 mrad, 1 mm
    result = lambda pose: SimpleNamespace(pose=pose, covariance=covariance,  # noqa: E731
                                          uncertainty=SimpleNamespace(well_constrained=True))
    truth = np.eye(4)
    near = check_covariance(result(_moved([0.0, 0.005, 0.0], [0.001, 0.0, 0.0])), "none", truth, MODEL, 1)
    far = check_covariance(result(_moved([0.0, 0.0, 0.0], [0.008, 0.0, 0.0])), "none", truth, MODEL, 1)
    flipped = check_covariance(result(_moved([0.0, 0.0, np.pi / 2], [0.0, 0.0, 0.0])), "none", truth, MODEL, 1)
    assert near.inside and near.in_basin and not far.inside and far.in_basin and not flipped.in_basin


def test_calibration_counts_only_well_constrained_estimates_in_the_right_basin():
    checks = [CovarianceCheck(True, True, True)] * 9 + [CovarianceCheck(True, True, False),
                                                         CovarianceCheck(False, True, False),
                                                         CovarianceCheck(True, False, False)]
    assert calibration(checks) == (0.9, 10)
    assert np.isnan(calibration([])[0]) and calibration([])[1] == 0
