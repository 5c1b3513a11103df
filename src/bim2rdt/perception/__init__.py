"""The perception front end: camera model, frames, detectors, corners, back-projection and registration.

``perceive_frame(frame, model, priors, detector=GeometricDetector(model))`` turns one RGB-D frame into
observations (one per object found); ``perceive_frames`` fuses several views of one place."""

from bim2rdt.perception.background import SLAB_CLASSES, explained, hit_depths, structure_for
from bim2rdt.perception.camera import CameraError, Intrinsics, look_at
from bim2rdt.perception.config import PerceptionConfig
from bim2rdt.perception.detection import Detection
from bim2rdt.perception.detector import Detector
from bim2rdt.perception.edges import EdgeFilter
from bim2rdt.perception.errors import PerceptionError
from bim2rdt.perception.frame import Frame
from bim2rdt.perception.geometric import GeometricConfig, GeometricDetector
from bim2rdt.perception.fitting import FitRules, Plausible, fit_detection
from bim2rdt.perception.library import element_body_mesh
from bim2rdt.perception.observation import UNKNOWN_FAMILY, ElementStatus, Observation
from bim2rdt.perception.perceive import PerceiveConfig, locate_detections, perceive_frame, perceive_frames
from bim2rdt.perception.slab import SLAB_CLEARANCE, off_the_slab
from bim2rdt.perception.structure import movable_elements, permanent_elements
from bim2rdt.perception.surfaces import KnownSurface
from bim2rdt.perception.visibility import DepthView, PlaceLook, look_at_place, see_through_fraction
from bim2rdt.perception.yoloe import YoloeDetector

__all__ = ["CameraError", "DepthView", "Detection", "Detector", "EdgeFilter", "element_body_mesh", "ElementStatus",
           "explained", "fit_detection", "FitRules", "Frame", "hit_depths", "GeometricConfig", "GeometricDetector",
           "Intrinsics", "KnownSurface", "locate_detections", "look_at", "look_at_place", "movable_elements",
           "Observation", "off_the_slab", "perceive_frame", "perceive_frames", "PerceiveConfig", "PerceptionConfig",
           "PerceptionError", "permanent_elements", "PlaceLook", "Plausible", "see_through_fraction", "SLAB_CLASSES",
           "SLAB_CLEARANCE", "structure_for", "UNKNOWN_FAMILY", "YoloeDetector"]
