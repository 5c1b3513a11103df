"""Registering one detected object in the mission: perception's one fitting path
(:func:`bim2rdt.perception.fitting.fit_detection`: slab contact, starts, the BIM pose winning a near-tie), with the
mission's settings. The mission searches yaw from every start, the detector's pose included
(``refine_detector_pose=False``): it verifies each planned element once and can afford the search that a frame's
time budget does not give perception's front end (docs/decisions/0003-one-observation-path.md)."""

from __future__ import annotations

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.records import Target
from bim2rdt.perception import Detection
from bim2rdt.perception import FitRules, Plausible, fit_detection
from bim2rdt.registration import IcpConfig, RegistrationResult
from bim2rdt.semantics import UprightPrior


def mission_rules(config: MissionConfig, icp: IcpConfig) -> FitRules:
    """The fitting rules under ``config``: its tie ratio and slab contact, a full search from every start."""
    return FitRules(icp, config.tie_ratio, config.slab_contact, refine_detector_pose=False)


def fit_target(detection: Detection, target: Target | None, model_pts: np.ndarray, model_normals: np.ndarray,
               object_pts: np.ndarray, prior: UprightPrior, config: MissionConfig, icp: IcpConfig,
               plausible: Plausible = lambda fit: True) -> RegistrationResult:
    """The kept fit of ``detection``'s ``object_pts`` (its points above the slab) to the model of ``target`` (its
    BIM element, None for an object the BIM lacks) on the mission's slab."""
    detector = [detection.pose] if detection.pose is not None else []
    return fit_detection(model_pts, model_normals, object_pts, target.placement if target else None, detector,
                         prior, config.slab_height, mission_rules(config, icp), plausible)
