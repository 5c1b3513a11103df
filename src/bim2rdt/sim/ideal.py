"""The ideal detector: the renderer's own instance masks with the true families. No real detector is this good;
benchmarks run it beside the real ones as the upper bound, and nothing in the library may use it."""

from __future__ import annotations

import numpy as np

from bim2rdt.perception.detection import Detection
from bim2rdt.perception.frame import Frame
from bim2rdt.sim.render import RgbdFrame
from bim2rdt.sim.views import object_roi


class IdealDetector:
    """Detections straight from a rendered frame's labels: every object with at least ``min_pixels`` pixels,
    its true family, its mask and its padded box (as a detector's box would be). :meth:`bind` it to the
    rendered frame before :meth:`detect`."""

    name = "ideal"

    def __init__(self, families: list[str], min_pixels: int = 150) -> None:
        self.families, self.min_pixels = families, min_pixels
        self._rendered: RgbdFrame | None = None

    def bind(self, rendered: RgbdFrame) -> IdealDetector:
        """Use ``rendered``'s labels for the next :meth:`detect` (the frame the robot sends carries none)."""
        self._rendered = rendered
        return self

    def detect(self, frame: Frame) -> list[Detection]:
        if self._rendered is None:
            raise RuntimeError("IdealDetector.detect before bind(rendered frame)")
        labels = self._rendered.labels
        seen, pixels = np.unique(labels[labels >= 0], return_counts=True)
        return [Detection(self.families[index], label=self.families[index], bbox=object_roi(labels, int(index)),
                          mask=labels == index, score=1.0, detector=self.name)
                for index, count in zip(seen, pixels) if count >= self.min_pixels]
