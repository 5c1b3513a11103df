"""The perception front end: camera model, frames, detectors, corners, back-projection and registration.

``perceive_frame(frame, model, priors, detector=GeometricDetector(model))`` turns one RGB-D frame into
observations (one per object found); ``perceive_frames`` fuses several views of one place."""

from bim2rdt.perception.background import explained, structure_for
from bim2rdt.perception.camera import CameraError, Intrinsics, look_at
from bim2rdt.perception.config import PerceptionConfig
from bim2rdt.perception.detection import Detection
from bim2rdt.perception.detector import Detector
from bim2rdt.perception.edges import EdgeFilter
from bim2rdt.perception.errors import PerceptionError
from bim2rdt.perception.frame import Frame
from bim2rdt.perception.geometric import GeometricConfig, GeometricDetector
from bim2rdt.perception.fitting import FitRules, fit_detection
from bim2rdt.perception.library import element_body_mesh
from bim2rdt.perception.observation import UNKNOWN_FAMILY, Observation
from bim2rdt.perception.perceive import PerceiveConfig, locate_detections, perceive_frame, perceive_frames
from bim2rdt.perception.structure import movable_elements, permanent_elements
from bim2rdt.perception.yoloe import YoloeDetector

__all__ = ["UNKNOWN_FAMILY", "CameraError", "Detection", "Detector", "EdgeFilter", "FitRules", "Frame",
           "GeometricConfig", "GeometricDetector", "Intrinsics", "Observation", "PerceiveConfig", "PerceptionConfig",
           "PerceptionError", "YoloeDetector", "element_body_mesh", "explained", "fit_detection", "locate_detections",
           "look_at", "movable_elements", "perceive_frame", "permanent_elements", "perceive_frames", "structure_for"]
