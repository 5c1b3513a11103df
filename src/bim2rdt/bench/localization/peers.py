"""Open3D's point-to-plane ICP as the peer of the BIM fix: the same depth points (the localizer's grid), the same
start (the filter's prediction), the same pair distance (the basin), Huber scale and iteration budget. Open3D is
6-DoF (it cannot hold the IMU's roll and pitch) and matches nearest neighbours, as a user would run it against
the BIM's permanent surfaces sampled on both faces of every wall; a second variant gets our visible samples
instead, to separate what the map does from what the solver does."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.evaluation.peers import import_open3d
from bim2rdt.localization import LocalizationConfig
from bim2rdt.localization import depth_points
from bim2rdt.localization.surfaces import PermanentMap
from bim2rdt.perception.frame import Frame

WHOLE_BIM_SPACING = 0.04
"""Sample spacing of the whole-BIM map, m (about the density of the visible samples at 4 m)."""


@dataclass(frozen=True)
class Open3dPointToPlane:
    """Open3D ``registration_icp`` with ``TransformationEstimationPointToPlane(HuberLoss)``."""

    config: LocalizationConfig
    visible_only: bool

    @property
    def name(self) -> str:
        return "Open3D pt-plane, visible BIM" if self.visible_only else "Open3D pt-plane"

    def __call__(self, frame: Frame, surfaces: PermanentMap, whole: tuple[np.ndarray, np.ndarray],
                 prior: np.ndarray) -> np.ndarray:
        """T_world_camera from ``prior``."""
        o3d = import_open3d()
        reg = o3d.pipelines.registration
        cfg = self.config
        points_cam = depth_points(frame, cfg.pixel_stride, cfg.min_range, cfg.max_range)
        if self.visible_only:
            seen = surfaces.visible(prior, frame.intrinsics, cfg.model_stride, cfg.view_margin, cfg.max_range * 1.2)
            map_points, map_normals = seen.points, seen.normals
        else:
            near = np.linalg.norm(whole[0] - prior[:3, 3], axis=1) < cfg.max_range * 1.2
            map_points, map_normals = whole[0][near], whole[1][near]
        target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(map_points))
        target.normals = o3d.utility.Vector3dVector(map_normals)
        source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points_cam))
        estimation = reg.TransformationEstimationPointToPlane(reg.HuberLoss(k=cfg.huber_delta))
        criteria = reg.ICPConvergenceCriteria(1e-6, 1e-6, cfg.max_iterations + cfg.polish_iterations)
        return np.asarray(reg.registration_icp(source, target, cfg.max_correction, prior, estimation,
                                               criteria).transformation)
