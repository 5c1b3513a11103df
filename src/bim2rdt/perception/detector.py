"""The detector strategy: anything with a ``name`` and ``detect(frame) -> list[Detection]``.

Detections carry a label, a family (a BIM family or ``"unknown"``), a bbox, a mask and a score; perception
turns each into world points and a registered pose (:func:`bim2rdt.perception.perceive_frame`)."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from bim2rdt.perception.detection import Detection
from bim2rdt.perception.frame import Frame


@runtime_checkable
class Detector(Protocol):
    """A perception front end's detector: the geometric one (no weights), YOLOE (extra ``yoloe``), or the
    simulator's ideal one (benchmarks only)."""

    name: str

    def detect(self, frame: Frame) -> list[Detection]:
        """Find the objects in one frame.

        Args:
            frame: A checked RGB-D frame (depth in metres).

        Returns:
            The detections, each with family, label, bbox (pixels), mask and score.
        """
        ...
