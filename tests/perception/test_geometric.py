"""The geometric detector: what the BIM's building does not explain, clustered and named by registration."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bim import load_ifc

from bim2rdt.perception import UNKNOWN_FAMILY, GeometricDetector, look_at
from bim2rdt.perception.background import BimStructure
from bim2rdt.sim.meshes import worker
from bim2rdt.sim.scene import PlacedObject, ground_pose

from tests.perception.conftest import CONE, DRUM, element, placed, render


def _shows(detection, rendered) -> int:
    labels = rendered.labels[detection.mask]
    labels = labels[labels >= 0]
    return int(np.bincount(labels).argmax()) if len(labels) else -1


def test_the_bare_building_holds_nothing_to_detect(site, priors):
    """Walls, columns, slab and door are the BIM's: a frame of them alone, flying pixels and all, is empty."""
    frame, _ = render(site, [], look_at((10.0, 3.0, 1.1), (15.0, 9.0, 0.5)))
    assert GeometricDetector(site, priors).detect(frame) == []


def test_a_cone_and_a_drum_are_found_masked_and_named(site, priors):
    drum = element(site, DRUM)
    objects = [placed(CONE, 13.4, 1.9, 30.0), placed(DRUM, *drum.position[:2])]
    frame, rendered = render(site, objects, look_at((10.5, 1.8, 1.1), (13.0, 2.3, 0.4)))
    detections = GeometricDetector(site, priors).detect(frame)
    named = {_shows(d, rendered): d for d in detections}
    assert set(named) == {0, 1}
    assert named[0].family == CONE and named[1].family == DRUM
    for index, detection in named.items():
        truth = rendered.labels == index
        assert (detection.mask & truth).sum() >= 0.8 * truth.sum()  # the mask covers the object ...
        assert (detection.mask & truth).sum() >= 0.6 * detection.mask.sum()  # ... and little else
        u0, v0, u1, v1 = detection.bbox
        assert truth[v0:v1, u0:u1].sum() >= 0.95 * truth.sum()  # the box holds the object (edges: flying pixels)
        assert detection.detector == "geometric" and 0.0 <= detection.score <= 1.0
    assert np.linalg.norm(named[1].pose[:2, 3] - drum.position[:2]) < 0.03


def test_a_worker_is_unknown_never_a_family(site, priors):
    """A person beside the drums is the one cluster no family explains."""
    person = PlacedObject("worker", worker(), ground_pose(14.6, 3.4, 0.3), colour=(0.9, 0.8, 0.1))
    frame, rendered = render(site, [placed(DRUM, 16.4, 2.6)], look_at((11.5, 2.5, 1.1), (15.0, 3.0, 0.6)),
                             workers=[person])
    detections = GeometricDetector(site, priors).detect(frame)
    on_worker = [d for d in detections if (rendered.labels[d.mask] == -4).mean() > 0.5]
    assert len(on_worker) == 1 and on_worker[0].family == UNKNOWN_FAMILY and on_worker[0].pose is None
    assert [d.family for d in detections if d not in on_worker] == [DRUM]


def test_an_object_the_bim_lacks_is_named_from_all_the_families(site, priors):
    """No BIM element near (5, 9): a drum there is named by trying every family of the model."""
    frame, _ = render(site, [placed(DRUM, 5.0, 9.0, 10.0)], look_at((5.0, 6.5, 1.1), (5.0, 9.0, 0.4)))
    [detection] = GeometricDetector(site, priors).detect(frame)
    assert detection.family == DRUM


def test_the_slab_height_comes_from_the_bim_not_a_constant(site, samples):
    assert BimStructure(site).slab_height(np.array([5.0, 5.0, 1.1])) == 0.0  # the embedded site's slab top
    house = BimStructure(load_ifc(samples / "AC20-FZK-Haus.ifc"))  # ArchiCAD: ground floor 0.0, upper floor 2.7 m
    assert house.slab_height(np.array([5.0, 5.0, 1.1])) == pytest.approx(0.0)
    assert house.slab_height(np.array([5.0, 5.0, 4.0])) == pytest.approx(2.7)  # a robot upstairs
    assert house.slab_height(np.array([30.0, 5.0, 1.1])) == pytest.approx(0.0)  # off every slab: the storey's
