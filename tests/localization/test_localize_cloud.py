"""localize_cloud: the 4-DoF BIM fix of a point cloud: a synthetic 360 degree scan in the embedded site, the real
office1 Kinect frame as a cloud (truth from office1_truth.json), and bad input."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from bim2rdt.localization import LocalizationConfig, LocalizationError, localize_cloud
from bim2rdt.perception import look_at

from loc_helpers import errors, offset

REAL_SENSOR = LocalizationConfig(inlier_distance=0.05, huber_delta=0.025, min_inlier_fraction=0.3)


def _scan_360(model, T_world_sensor, step_deg=0.7, noise=0.005, seed=0):
    """Points (sensor frame) where rays all round from the sensor first hit the model's walls, slabs and every
    other body: built here from the model's meshes, not by the code under test."""
    meshes = [trimesh.Trimesh(*model.mesh(el.global_id), process=False) for el in model.elements
              if model.has_mesh(el.global_id) and el.ifc_class not in ("IfcSpace", "IfcOpeningElement")]
    mesh = trimesh.util.concatenate(meshes)
    azimuth, elevation = np.meshgrid(np.deg2rad(np.arange(0, 360, step_deg)), np.deg2rad(np.arange(-60, 60, step_deg)))
    directions = np.stack([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                           np.sin(elevation)], axis=-1).reshape(-1, 3)
    origin = T_world_sensor[:3, 3]
    locations, rays, _ = mesh.ray.intersects_location(np.broadcast_to(origin, directions.shape), directions,
                                                      multiple_hits=False)
    near = np.linalg.norm(locations - origin, axis=1) < 8.0
    rng = np.random.default_rng(seed)
    points_world = locations[near] + directions[rays[near]] * rng.normal(0, noise, (near.sum(), 1))
    return (points_world - origin) @ T_world_sensor[:3, :3]


def test_a_360_degree_scan_is_fixed_from_a_prior_off_by_25_cm_and_5_degrees(site_model):
    T_true = look_at((8.5, 2.0, 1.1), (11.85, 6.5, 1.1))
    cloud = SimpleNamespace(points=_scan_360(site_model, T_true))
    behind = np.einsum("ni,i->n", cloud.points, (0, 0, 1)) < 0
    assert behind.mean() > 0.3  # the scan does look behind the sensor: no single view
    loc = localize_cloud(cloud, site_model, offset(T_true, 0.2, -0.15, 5.0))
    shift, yaw = errors(loc.pose, T_true)
    assert np.linalg.norm(shift) < 0.02 and abs(yaw) < 0.3
    assert loc.inliers > 500 and loc.residual < 0.02
    assert loc.covariance.shape == (6, 6)


@pytest.fixture(scope="module")
def office(office1):
    """office1's model, its frame as a cloud (every valid depth pixel back-projected) and its true pose."""
    frame = office1.frame
    valid = frame.valid_depth
    v, u = np.nonzero(valid)
    points = frame.intrinsics.backproject(np.stack([u, v], axis=1).astype(float), frame.depth[valid].astype(float))
    return office1.model, SimpleNamespace(points=points), office1.T_world_camera


@pytest.mark.parametrize("dx, dy, dyaw", [(0.14, 0.14, 5.0), (-0.2, 0.0, -5.0)])
def test_office1_as_a_cloud_is_fixed_within_3_cm_and_1_degree_of_the_truth(office, dx, dy, dyaw):
    model, cloud, T_true = office
    loc = localize_cloud(cloud, model, offset(T_true, dx, dy, dyaw), config=REAL_SENSOR)
    shift, yaw = errors(loc.pose, T_true)
    turned = np.rad2deg(np.arccos(np.clip((np.trace(loc.pose[:3, :3].T @ T_true[:3, :3]) - 1) / 2, -1, 1)))
    assert np.linalg.norm(shift) < 0.03 and abs(yaw) < 1.0 and turned < 1.0


def test_bad_clouds_are_refused_in_one_line(office):
    model, cloud, T_true = office
    with pytest.raises(LocalizationError, match=r"\.points"):
        localize_cloud(object(), model, T_true)
    with pytest.raises(LocalizationError, match=r"\(N, 3\)"):
        localize_cloud(SimpleNamespace(points=np.zeros((10, 2))), model, T_true)
    with pytest.raises(LocalizationError, match="returns"):
        localize_cloud(SimpleNamespace(points=np.full((500, 3), np.nan)), model, T_true)
    with pytest.raises(LocalizationError, match="4x4"):
        localize_cloud(cloud, model, np.eye(3))
    far = T_true.copy()
    far[:3, 3] += (30.0, 0.0, 0.0)  # nothing of the model within reach: no permanent element seen
    with pytest.raises(LocalizationError, match="sees no permanent element"):
        localize_cloud(cloud, model, far, config=REAL_SENSOR)


def test_a_cloud_fix_that_turned_beyond_a_smaller_basin_is_rejected_naming_the_sensor(office):
    model, cloud, T_true = office
    narrow = REAL_SENSOR.model_copy(update={"max_correction_deg": 3.0})
    with pytest.raises(LocalizationError, match=r"moved the sensor 0\.\d\d m and turned it [45]\.\d deg .* beyond the "
                                                r"basin \(0\.\d+ m, 3\.0 deg\): rejected"):
        localize_cloud(cloud, model, offset(T_true, 0.0, 0.0, 5.0), config=narrow)
