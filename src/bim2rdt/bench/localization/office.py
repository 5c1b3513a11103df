"""The real office frame (``pcl/office1.pcd``, a Kinect v1 frame, with ``office1.ifc`` authored from it): the BIM fix
of ``localization.localize`` (the frame localizer) from priors scattered around the truth, with the depth
correction and without; and of ``localization.localize_cloud`` (what ``bim2rdt verify`` runs: the frame as a cloud,
the model's furniture occluding the ray cast, verify's real-sensor settings) from the same priors, corrected.

Priors are sampled uniformly within ``radius`` m (a ball around the true camera position) and ``yaw_deg`` of
the true heading; roll and pitch are the truth's (what an IMU gives). The truth (``office1_truth.json``) is read
here only to make the priors and score the fixes. Times are CPU seconds per fix (for the cloud localizer with the
cloud's thinning and normals, as verify pays them per frame).
"""

from __future__ import annotations

import json
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bim2rdt.bench.localization.run import PoseError, pose_error
from bim2rdt.bim import load_ifc
from bim2rdt.localization import LocalizationConfig, LocalizationError, localize, localize_cloud, scan_points
from bim2rdt.sources import open_source, read_cloud
from bim2rdt.verify.chain import real_sensor_localization

PRIORS = 20
RADIUS_M = 0.30
YAW_DEG = 8.0
FRAME = Path("pcl") / "office1.pcd"


@dataclass(frozen=True)
class OfficeFix:
    """One prior's result: how far the prior was off, and the fix's error (None when refused, with the reason)."""

    prior: PoseError
    fix: PoseError | None
    reason: str | None
    seconds: float
    pose: np.ndarray | None = None
    """The fix's T_world_camera (4, 4), None when refused."""
    kind: str | None = None
    """The refusal's kind (:class:`~bim2rdt.localization.Refusal`'s value), None when accepted."""


def office_priors(T_true: np.ndarray, count: int = PRIORS, radius: float = RADIUS_M, yaw_deg: float = YAW_DEG,
                  seed: int = 0) -> list[np.ndarray]:
    """``count`` priors T_world_camera: the true pose turned about world z by up to ``yaw_deg`` and moved by up
    to ``radius`` m (uniform in the ball), roll and pitch kept."""
    rng = np.random.default_rng(seed)
    priors = []
    for _ in range(count):
        direction = rng.normal(size=3)
        offset = direction / np.linalg.norm(direction) * radius * rng.uniform() ** (1 / 3)
        yaw = np.deg2rad(rng.uniform(-yaw_deg, yaw_deg))
        c, s = np.cos(yaw), np.sin(yaw)
        prior = T_true.copy()
        prior[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ T_true[:3, :3]
        prior[:3, 3] = T_true[:3, 3] + offset
        priors.append(prior)
    return priors


def run_office(sensors: Path, config: LocalizationConfig | None = None, count: int = PRIORS, seed: int = 0,
               cache_dir: Path | None = None, cloud_config: LocalizationConfig | None = None) -> dict:
    """The office frame localized from ``count`` priors: by ``localize`` with the truth file's depth correction
    ("corrected") and without it ("raw"), and by ``localize_cloud`` corrected, with ``cloud_config`` (default:
    verify's :func:`~bim2rdt.verify.chain.real_sensor_localization`). JSON-able, per prior and summarized."""
    folder = Path(sensors) / "pcl"
    truth = json.loads((folder / "office1_truth.json").read_text())
    T_true = np.array(truth["T_world_camera"], dtype=np.float64)
    g = truth["depth_correction"]["g"]
    model = load_ifc(folder / "office1.ifc", cache_dir=cache_dir)
    priors = office_priors(T_true, count, seed=seed)
    variants = {}
    for name, correction in (("corrected", g), ("raw", None)):
        [frame] = list(open_source(Path(sensors) / FRAME, depth_correction=correction))
        fixes = [_fix(frame, model, prior, T_true, config) for prior in priors]
        variants[name] = {"summary": _summary(fixes), "fixes": [_record(f) for f in fixes]}
    cloud_cfg = cloud_config or real_sensor_localization()
    cloud = read_cloud(Path(sensors) / FRAME, depth_correction=g)
    cloud_fixes = [_cloud_fix(cloud, model, prior, T_true, cloud_cfg) for prior in priors]
    return {"frame": str(FRAME), "priors": count, "radius_m": RADIUS_M, "yaw_deg": YAW_DEG, "seed": seed,
            "depth_correction": g, "variants": variants,
            "cloud": {"localizer": "localize_cloud", "depth": "corrected", "config": cloud_cfg.model_dump(),
                      "summary": _summary(cloud_fixes), "fixes": [_record(f) for f in cloud_fixes]}}


def _fix(frame, model, prior, T_true, config) -> OfficeFix:
    started = time.process_time()
    try:
        fix = localize(frame, model, prior, config=config)
    except LocalizationError as error:
        return OfficeFix(pose_error(prior, T_true), None, str(error), time.process_time() - started,
                         kind=error.kind.value)
    return OfficeFix(pose_error(prior, T_true), pose_error(fix.pose, T_true), None, time.process_time() - started,
                     fix.pose)


def _cloud_fix(cloud, model, prior, T_true, config: LocalizationConfig) -> OfficeFix:
    """As verify fixes a frame: the cloud thinned with normals, then ``localize_cloud`` from ``prior``."""
    started = time.process_time()
    try:
        fix = localize_cloud(scan_points(cloud, config), model, prior, (0.0, 0.0, 1.0), config)
    except LocalizationError as error:
        return OfficeFix(pose_error(prior, T_true), None, str(error), time.process_time() - started,
                         kind=error.kind.value)
    return OfficeFix(pose_error(prior, T_true), pose_error(fix.pose, T_true), None, time.process_time() - started,
                     fix.pose)


def _summary(fixes: list[OfficeFix]) -> dict:
    accepted = [f.fix for f in fixes if f.fix is not None]
    reasons = dict(Counter(f.kind for f in fixes if f.kind is not None))

    def stat(values, how):
        return float(how(values)) if values else None

    return {"accepted": len(accepted), "refused": len(fixes) - len(accepted), "refusals": reasons,
            "median_position_cm": stat([e.position * 100 for e in accepted], np.median),
            "worst_position_cm": stat([e.position * 100 for e in accepted], np.max),
            "median_yaw_deg": stat([abs(e.yaw_deg) for e in accepted], np.median),
            "worst_yaw_deg": stat([abs(e.yaw_deg) for e in accepted], np.max),
            "median_prior_cm": float(np.median([f.prior.position * 100 for f in fixes])),
            "median_seconds": float(np.median([f.seconds for f in fixes]))}


def _record(fix: OfficeFix) -> dict:
    return {"prior_position_cm": fix.prior.position * 100, "prior_yaw_deg": fix.prior.yaw_deg,
            "position_cm": None if fix.fix is None else fix.fix.position * 100,
            "yaw_deg": None if fix.fix is None else fix.fix.yaw_deg, "reason": fix.reason, "seconds": fix.seconds,
            "pose": None if fix.pose is None else fix.pose.tolist()}
