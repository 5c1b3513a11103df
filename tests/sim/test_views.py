"""Scene points of an object: ROI corners with depth, mostly on the object's surface."""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from bim2rdt.sim.meshes import wooden_crate
from bim2rdt.sim.render import add_sensor_noise, cast_frame
from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.sim.scene import PlacedObject, SiteScene
from bim2rdt.sim.views import object_roi, object_scene_points


def test_corner_points_lie_mostly_on_the_seen_object():
    crate = wooden_crate()
    site = SiteScene([PlacedObject("crate", crate, np.eye(4), 0.6)])
    camera = look_at((1.5, -2.0, 1.4), (0.0, 0.0, 0.3))
    frame = add_sensor_noise(cast_frame(site, Intrinsics(), camera), np.random.default_rng(1))
    points = object_scene_points(frame, Intrinsics(), 0, np.random.default_rng(2))
    assert 100 <= len(points) <= 630
    surface, _ = trimesh.sample.sample_surface(crate, 50_000, seed=0)  # ~1 cm apart
    distance, _ = cKDTree(surface).query(points)
    assert np.mean(distance < 0.02) > 0.45  # about half; the rest: ground in the ROI, silhouette mixes, spurious


def test_an_unseen_object_has_no_roi_and_no_points():
    labels = np.full((10, 10), -1)
    assert object_roi(labels, 0) is None
