"""Registration methods compared by the benchmark, behind one call signature so the loop has no if-chains.

``method(model_pts, model_normals, scene_pts_world, T_init, bias, yaw_only, support_height)`` returns T_world_model
or, for bim2rdt's own loop, the whole RegistrationResult (with its covariance); ``support_height`` is the slab
the object rests on (m), or None when the scene does not know it. Every method
gets the same yaw restarts (:func:`bim2rdt.registration.icp.yaw_restarts`), the same iteration cap and pair
distance, and picks its best restart with the same truncated score.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.errors import Bim2RdtError
from bim2rdt.registration import IcpConfig, RegistrationResult, register
from bim2rdt.registration.icp import score_poses, yaw_restarts
from bim2rdt.registration.matching import ModelIndex
from bim2rdt.registration.so3 import invert_poses

UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class SgIcp:
    """bim2rdt's loop: plain robust ICP when ``use_prior`` is False; SG-ICP with the family prior otherwise, resting
    on the scene's support when it is known (``contact``), or, with ``contact`` False, on the upright prior
    alone (the ablation that shows what the contact adds)."""

    config: IcpConfig
    use_prior: bool
    contact: bool = True

    @property
    def name(self) -> str:
        if not self.use_prior:
            return "ICP"
        return "SG-ICP" if self.contact else "SG-ICP upright only"

    def __call__(self, model_pts, model_normals, scene_pts, T_init, bias, yaw_only,
                 support_height: float | None = 0.0) -> RegistrationResult:
        if not self.use_prior:
            return register(model_pts, model_normals, scene_pts, T_init, UP, 0.0, False, self.config)
        start = level(T_init) if yaw_only else T_init
        return register(model_pts, model_normals, scene_pts, start, UP, bias, yaw_only, self.config,
                        support_height=support_height if self.contact else None)


@dataclass(frozen=True)
class Open3dIcp:
    """Open3D's ``registration_icp`` (point-to-point, or point-to-plane with a Huber kernel), run once per
    restart from the same starts as ours; the scene is the source, the model samples with normals the target."""

    config: IcpConfig
    plane: bool

    @property
    def name(self) -> str:
        return "Open3D pt-plane" if self.plane else "Open3D pt-pt"

    def __call__(self, model_pts, model_normals, scene_pts, T_init, bias, yaw_only,
                 support_height: float | None = 0.0) -> np.ndarray:
        o3d = import_open3d()
        reg = o3d.pipelines.registration
        target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(model_pts))
        target.normals = o3d.utility.Vector3dVector(model_normals)
        source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(scene_pts))
        estimation = (reg.TransformationEstimationPointToPlane(reg.HuberLoss(k=self.config.huber_delta))
                      if self.plane else reg.TransformationEstimationPointToPoint())
        criteria = reg.ICPConvergenceCriteria(1e-6, 1e-6, self.config.max_iterations)
        starts = yaw_restarts(T_init, model_pts.mean(axis=0), UP, self.config)
        poses = np.stack([invert_poses(reg.registration_icp(
            source, target, self.config.max_pair_distance, invert_poses(T), estimation, criteria).transformation)
            for T in starts])
        scores, _ = score_poses(ModelIndex.cached(model_pts, model_normals), poses, scene_pts, self.config)
        return poses[int(np.argmin(scores))]


def level(T: np.ndarray) -> np.ndarray:
    """The pose with its tilt removed: same position, same heading of the body x axis, body z along world up."""
    heading = np.arctan2(T[1, 0], T[0, 0]) if abs(T[2, 0]) < 0.99 else np.arctan2(-T[0, 1], T[1, 1])
    out = np.eye(4)
    out[:2, :2] = [[np.cos(heading), -np.sin(heading)], [np.sin(heading), np.cos(heading)]]
    out[:3, 3] = T[:3, 3]
    return out


class PeerUnavailable(Bim2RdtError):
    """An optional peer (extra ``bench``) is not installed."""


def import_open3d():
    """open3d, or a one-line error naming the extra that provides it."""
    try:
        import open3d
    except ImportError as error:
        raise PeerUnavailable(f"open3d is not importable ({error}); install the extra: pip install -e '.[bench]'"
                              ) from error
    return open3d
