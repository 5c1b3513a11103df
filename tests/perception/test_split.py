"""Touching objects make one cluster: the geometric detector names the part a family explains and the rest apart."""

from __future__ import annotations

import numpy as np

from bim2rdt.perception import GeometricDetector, look_at

from tests.perception.conftest import CONE, DRUM, placed, render


def test_a_drum_left_against_a_cone_is_two_detections_not_one(site, priors):
    """No BIM drum near (2.5, 2.2), and a cone right beside it: one cluster holds both."""
    objects = [placed(DRUM, 2.5, 2.2), placed(CONE, 2.99, 2.2)]  # base 7 mm, body 5 cm from the drum
    frame, rendered = render(site, objects, look_at((2.75, 0.4, 1.1), (2.75, 2.2, 0.4)))
    detections = GeometricDetector(site, priors).detect(frame)
    shows = {}
    for d in detections:
        labels = rendered.labels[d.mask]
        labels = labels[labels >= 0]
        shows[int(np.bincount(labels).argmax())] = d.family
    assert shows == {0: DRUM, 1: CONE}
