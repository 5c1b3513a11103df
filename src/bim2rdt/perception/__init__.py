"""The perception front end: camera model, frames, detections, corners and back-projection."""

from bim2rdt.perception.camera import CameraError, Intrinsics, look_at
from bim2rdt.perception.detection import Detection
from bim2rdt.perception.errors import PerceptionError
from bim2rdt.perception.frame import Frame
from bim2rdt.perception.observation import UNKNOWN_FAMILY, Observation

__all__ = ["UNKNOWN_FAMILY", "CameraError", "Detection", "Frame", "Intrinsics", "Observation", "PerceptionError",
           "look_at"]
