"""verify_frames on a scan: a synthetic 360 degree scan of the embedded site, its objects where the BIM puts
them, localized from a prior off by 25 cm and 5 degrees; nothing called deviating, and every item refused with
its reason rather than an exception."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from bim2rdt.perception import look_at
from bim2rdt.verify import VerifyError, verify_frames


def _scan(model, T_world_sensor, step_deg=0.7, noise=0.004):
    """Points (sensor frame) where rays all round first hit the model's bodies: built here, not by verify."""
    meshes = [trimesh.Trimesh(*model.mesh(el.global_id), process=False) for el in model.elements
              if model.has_mesh(el.global_id) and el.ifc_class not in ("IfcSpace", "IfcOpeningElement")]
    mesh = trimesh.util.concatenate(meshes)
    azimuth, elevation = np.meshgrid(np.deg2rad(np.arange(0, 360, step_deg)), np.deg2rad(np.arange(-60, 60, step_deg)))
    directions = np.stack([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                           np.sin(elevation)], axis=-1).reshape(-1, 3)
    origin = T_world_sensor[:3, 3]
    hits, rays, _ = mesh.ray.intersects_location(np.broadcast_to(origin, directions.shape), directions,
                                                 multiple_hits=False)
    near = np.linalg.norm(hits - origin, axis=1) < 8.0
    points = hits[near] + directions[rays[near]] * np.random.default_rng(0).normal(0, noise, (near.sum(), 1))
    return (points - origin) @ T_world_sensor[:3, :3]


def test_a_360_degree_scan_is_localized_and_its_planned_objects_are_not_deviating(site_model, tmp_path):
    T_true = look_at((8.5, 2.0, 1.1), (11.85, 6.5, 1.1))
    cloud = SimpleNamespace(points=_scan(site_model, T_true), path=tmp_path / "scan.ply")
    prior = T_true.copy()
    prior[:3, 3] += (0.2, -0.15, 0.0)
    result = verify_frames([cloud], site_model, prior)
    frame = result.frames[0]
    assert frame.accepted and frame.source == "scan.ply", frame.reason
    assert np.linalg.norm(frame.pose[:3, 3] - T_true[:3, 3]) < 0.03
    assert not result.miscalibrated
    planned = [o for o in frame.observations if o.global_id is not None]
    assert planned, "no planned object checked in a scan all round the site"
    for o in planned:
        assert np.linalg.norm(o.pose[:3, 3] - site_model.element(o.global_id).placement[:3, 3]) < 0.05, o.family


@pytest.mark.parametrize("axes", ["z-up", "y-up"])
def test_a_360_degree_scan_without_a_prior_is_found_whichever_axis_it_was_written_up(site_model, tmp_path, axes):
    """A tripod scan at (14, 9), 1.5 m up, heading 200 degrees, with no prior and no IMU. Written y-up, a wall
    within 3 m behind it passes for a floor along the scanner's usual z: the other axes' floors are searched
    too, and the BIM tells the right one."""
    c, s = np.cos(np.deg2rad(200.0)), np.sin(np.deg2rad(200.0))
    T_true = np.eye(4)
    T_true[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    T_true[:3, 3] = (14.0, 9.0, 1.5)
    points = _scan(site_model, T_true)
    to_written = np.eye(3) if axes == "z-up" else np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    cloud = SimpleNamespace(points=points @ to_written.T, path=tmp_path / "scan.ply")
    frame = verify_frames([cloud], site_model, None).frames[0]
    assert frame.accepted and frame.prior_source == "global", frame.reason
    T_found = frame.pose
    assert np.linalg.norm(T_found[:3, 3] - T_true[:3, 3]) < 0.03
    assert np.allclose(T_found[:3, :3] @ to_written, T_true[:3, :3], atol=np.sin(np.deg2rad(1.0)))


def test_a_scan_without_a_prior_is_searched_and_refused_with_its_reason_and_no_frames_is_an_error(site_model):
    result = verify_frames([SimpleNamespace(points=np.zeros((10, 3)))], site_model, None)
    frame = result.frames[0]
    assert not frame.accepted and frame.prior_source == "global"
    assert frame.reason.startswith("global search: the cloud has 0 returns"), frame.reason
    with pytest.raises(VerifyError, match="no frames"):
        verify_frames([], site_model, np.eye(4))


def test_a_recordings_own_poses_carry_the_last_fix_forward_as_odometry():
    from bim2rdt.localization import GlobalSearchConfig
    from bim2rdt.perception import Frame, Intrinsics
    from bim2rdt.verify.tracking import Tracker

    def frame(own):
        return Frame(np.zeros((3, 4, 3), np.uint8), np.ones((3, 4), np.float32), Intrinsics(4, 3, 2.0, 2.0, 2.0, 1.5),
                     own)

    shift = np.eye(4)
    shift[:3, 3] = (1.0, 0.0, 0.0)
    own_0, own_1 = np.eye(4), shift  # the recording moved 1 m along its own x
    fix_0 = look_at((5.0, 5.0, 1.2), (5.0, 9.0, 1.2))  # where the BIM put its first frame
    tracker = Tracker(None, None, GlobalSearchConfig())
    first = tracker.prior(frame(own_0), np.zeros((0, 3)))
    assert first.source == "source" and first.pose is own_0  # no anchor yet: the recording's own pose
    tracker.update(first, fix_0, True)
    second = tracker.prior(frame(own_1), np.zeros((0, 3)))
    assert second.source == "source" and np.allclose(second.pose, fix_0 @ shift)  # 1 m along the fixed x
    scans = Tracker(None, fix_0, GlobalSearchConfig())
    scan = SimpleNamespace(points=np.zeros((5, 3)))
    assert scans.prior(scan, scan.points).source == "user" and scans.prior(scan, scan.points).pose is scans.user


class _Recording:
    """A recording as sources declares it (kind, expected_frames, dropped, warnings): two scans, one drop."""

    kind = "scan"
    expected_frames = 2

    def __init__(self, items) -> None:
        self.items, self.dropped, self.warnings = items, [], ["clocks disagree: test"]

    def __iter__(self):
        self.dropped = [{"time": 1.0, "reason": "no depth image within 20 ms", "kind": "no depth partner"}]
        return iter(self.items)


def test_verify_reads_what_a_recording_reports_and_builds_the_map_once(site_model, tmp_path, monkeypatch):
    from bim2rdt.localization import OccludedMap
    from bim2rdt.sources import Recording

    T_true = look_at((8.5, 2.0, 1.1), (11.85, 6.5, 1.1))
    scan = SimpleNamespace(points=_scan(site_model, T_true, step_deg=1.4), path=tmp_path / "a.ply")
    empty = SimpleNamespace(points=np.zeros((3, 3)), path=tmp_path / "b.ply")
    recording = _Recording([scan, empty])
    assert isinstance(recording, Recording)
    built = []
    of = OccludedMap.of.__func__
    monkeypatch.setattr(OccludedMap, "of", classmethod(lambda cls, model: built.append(model) or of(cls, model)))
    result = verify_frames(recording, site_model, T_true)
    assert len(built) == 1  # once per run, handed to every fix (and the depth check)
    assert result.frames[0].accepted and not result.frames[1].accepted
    assert result.drop_counts == {"no depth partner": 1} and result.source_warnings == ["clocks disagree: test"]


def test_a_scan_over_max_scan_points_is_thinned_evenly_and_says_so(site_model, tmp_path):
    """Three jittered copies of a scan (the scanner's order kept) over a cap of 100,000: every second return is
    kept, the scan is still localized, and the run warns what was thinned. A frame's pixels are never thinned."""
    from bim2rdt.verify.chain import VerifyConfig, sensor_points

    T_true = look_at((8.5, 2.0, 1.1), (11.85, 6.5, 1.1))
    one = _scan(site_model, T_true)
    rng = np.random.default_rng(1)
    points = np.concatenate([one + rng.normal(0.0, 0.002, one.shape) for _ in range(3)])
    points[5] = np.nan
    cloud = SimpleNamespace(points=points, path=tmp_path / "big.e57")
    kept = sensor_points(cloud, 100_000)
    k = -(-len(points) // 100_000)
    assert len(kept) <= 100_000 and np.array_equal(kept, points[::k][np.isfinite(points[::k]).all(axis=1)])
    assert len(sensor_points(cloud)) == len(points) - 1
    prior = T_true.copy()
    prior[:3, 3] += (0.2, -0.15, 0.0)
    result = verify_frames([cloud], site_model, prior, VerifyConfig(max_scan_points=100_000))
    assert result.frames[0].accepted, result.frames[0].reason
    assert any(w.startswith(f"big.e57: {len(points):,} returns thinned evenly to {len(kept):,}")
               for w in result.source_warnings), result.source_warnings
