"""Scene points of one object as the paper's pipeline gets them: a detector-like ROI around the object, Shi-Tomasi
corners inside it, depth at each corner, back-projection to the world, plus spurious returns.

The ROI is the object's pixel bounding box padded by 10 % (a detection box), so it also holds ground and any
neighbour or occluder: those corners are the real clutter a registration must survive. Spurious returns
(multipath, dust, thin cables) are scattered through the ROI's depth range.
"""

from __future__ import annotations

import numpy as np

from bim2rdt import exact
from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.corners import shi_tomasi
from bim2rdt.perception.edges import EdgeFilter, depth_at
from bim2rdt.sim.render import RgbdFrame


def object_roi(labels: np.ndarray, index: int, pad: float = 0.1) -> tuple[int, int, int, int] | None:
    """Padded pixel bounding box (u0, v0, u1, v1) of an object's visible pixels, or None if it is not seen."""
    vs, us = np.nonzero(labels == index)
    if len(us) == 0:
        return None
    du, dv = pad * (us.max() - us.min() + 1), pad * (vs.max() - vs.min() + 1)
    height, width = labels.shape
    return (max(0, int(us.min() - du)), max(0, int(vs.min() - dv)),
            min(width, int(us.max() + du) + 1), min(height, int(vs.max() + dv) + 1))


def object_scene_points(frame: RgbdFrame, intrinsics: Intrinsics, index: int, rng: np.random.Generator,
                        max_corners: int = 600, clutter_fraction: float = 0.05,
                        edge_filter: EdgeFilter | None = None) -> np.ndarray:
    """World points (N, 3) for object ``index``: ROI corners with valid depth plus spurious returns; with
    ``edge_filter``, a corner on a flying pixel takes the nearest surface's depth beside it
    (:func:`~bim2rdt.perception.edges.depth_at`). Empty (0, 3) when the object is not visible."""
    roi = object_roi(frame.labels, index)
    if roi is None:
        return np.zeros((0, 3))
    uv = shi_tomasi(frame.gray, roi, max_corners=max_corners)
    pixels = np.round(uv).astype(int)
    if edge_filter is None:
        depth = frame.depth[pixels[:, 1], pixels[:, 0]]
    else:
        depth = depth_at(edge_filter.apply(frame.depth), uv)
    seen = np.isfinite(depth)
    points_cam = intrinsics.backproject(uv[seen], depth[seen])
    points_cam = np.vstack([points_cam, _spurious(roi, depth[seen], intrinsics, rng, clutter_fraction)])
    return exact.transform(frame.T_world_camera, points_cam)


def _spurious(roi, depths: np.ndarray, intrinsics: Intrinsics, rng: np.random.Generator,
              fraction: float) -> np.ndarray:
    count = int(round(fraction * len(depths)))
    if count == 0 or len(depths) == 0:
        return np.zeros((0, 3))
    u0, v0, u1, v1 = roi
    uv = np.c_[rng.uniform(u0, u1, count), rng.uniform(v0, v1, count)]
    z = rng.uniform(depths.min() - 0.3, depths.max() + 0.3, count)
    return intrinsics.backproject(uv, np.maximum(z, 0.2))
