"""BIM-anchored localization of one RGB-D frame: where the camera is, from the walls, columns and slabs it sees.

1. depth pixels on a grid -> camera-frame points (``depth``);
2. the BIM's permanent surfaces ray cast from the prior pose (``surfaces``): only faces the camera could see,
   so the back of a wall is never a candidate (sparsely: the coarse pass pairs points up to the basin away);
3. the points within the basin of that surface are registered to it by the registration engine in its
   ``yaw_only`` mode: the IMU fixes roll and pitch, the view fixes yaw and position (4 degrees of freedom);
   robust weights and trimming leave site objects, people and clutter out;
4. the surface is ray cast again from the coarse fix, twice as densely, and the fit polished (the true view's
   visible surface);
5. the pairs' information gives the covariance and the directions the view cannot constrain (``observability``);
6. a fix that moved farther than the basin, or that explains too few of the points, is rejected, never trusted.

Steps 2-6 are :func:`~bim2rdt.localization.core.fix_pose`, shared with ``localize_cloud``; what is a camera's
own (its grid, its image's rays) is :class:`CameraView`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.core import Localization, behind_fraction, checked_up, fix_pose, rigid_prior
from bim2rdt.localization.depth import depth_grid, grid_normals
from bim2rdt.localization.errors import LocalizationError, Refusal
from bim2rdt.localization.surfaces import PermanentMap, SurfaceSamples, permanent_map
from bim2rdt.perception import Frame, Intrinsics

def localize(frame: Frame, model: BimModel, prior_T_world_camera: np.ndarray,
             up: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 1.0),
             config: LocalizationConfig | None = None) -> Localization:
    """Fix the camera pose of a frame on the permanent elements of the model (walls, columns, slabs, stairs,
    doors), starting from the odometry prior. Yaw-only ICP: roll and pitch of the prior are kept.
    ``frame.T_world_camera`` is ignored.

    Args:
        frame: The RGB-D frame (depth in metres, OpenCV camera axes).
        model: The BIM, loaded with geometry.
        prior_T_world_camera: 4x4 camera-to-world odometry prior, metres.
        up: The world up measured by the IMU, a unit 3-vector.
        config: Localization's settings; None uses the defaults.

    Returns:
        The fix: ``pose`` (``T_world_camera``, 4x4), its (6,6) covariance and information, the directions it
            cannot fix, and its residual (metres).

    Raises:
        LocalizationError: Too few depth returns, no permanent element in view, a correction beyond the basin,
            or a bad prior or up; the message gives the reason, ``kind`` its kind.
    """
    cfg = config or LocalizationConfig()
    prior, up_world = rigid_prior(prior_T_world_camera), checked_up(up)
    return fix_pose(CameraView.of(frame, permanent_map(model), cfg), prior, up_world, cfg)


@dataclass(frozen=True)
class CameraView:
    """A camera frame as the fix sees it (:class:`~bim2rdt.localization.core.SensorView`): its depth on a
    ``pixel_stride`` grid, normals from the grid, and the BIM ray cast through its image (widened by
    ``view_margin``), every ``coarse_model_stride``-th pixel for the coarse pass and ``model_stride``-th after."""

    points: np.ndarray
    normals: np.ndarray
    surfaces: PermanentMap
    intrinsics: Intrinsics
    cfg: LocalizationConfig
    sensor: str = "camera"
    returns: str = "depth points"
    needs_normals: bool = True

    @classmethod
    def of(cls, frame: Frame, surfaces: PermanentMap, cfg: LocalizationConfig) -> CameraView:
        """The frame's grid points in [min_range, max_range]; :class:`LocalizationError` when fewer than
        ``min_points``.

        Args:
            frame: The RGB-D frame.
            surfaces: The model's permanent map.
            cfg: Localization's settings.

        Returns:
            The view.
        """
        grid = depth_grid(frame, cfg.pixel_stride, cfg.min_range, cfg.max_range)
        valid = np.isfinite(grid[..., 2])
        if valid.sum() < cfg.min_points:
            raise LocalizationError(f"the frame has {int(valid.sum())} depth returns in {cfg.min_range}-"
                                    f"{cfg.max_range} m on its {cfg.pixel_stride}-pixel grid, need {cfg.min_points}",
                                    Refusal.TOO_FEW_RETURNS)
        return cls(grid[valid], grid_normals(grid)[valid], surfaces, frame.intrinsics, cfg)

    def visible(self, T_world_sensor: np.ndarray, coarse: bool) -> SurfaceSamples:
        """The permanent surface seen through the image from ``T_world_sensor`` (world samples and normals).

        Args:
            T_world_sensor: 4x4 camera pose.
            coarse: Sample every ``coarse_model_stride``-th pixel instead of every ``model_stride``-th.

        Returns:
            The samples.
        """
        stride = self.cfg.coarse_model_stride if coarse else self.cfg.model_stride
        return self.surfaces.visible(T_world_sensor, self.intrinsics, stride, self.cfg.view_margin,
                                     self.cfg.max_range * 1.2)

    def behind(self, T_world_sensor: np.ndarray, tolerance: float) -> float:
        """Fraction of the depth points beyond the first permanent surface on their ray (see
        :func:`~bim2rdt.localization.core.behind_fraction`).

        Args:
            T_world_sensor: 4x4 camera pose.
            tolerance: Metres past the surface allowed.

        Returns:
            The fraction.
        """
        return behind_fraction(self.points, T_world_sensor, self.surfaces, tolerance)
