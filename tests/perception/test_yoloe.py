"""YoloeDetector on real ultralytics code (extra ``yoloe``): YOLOE built from its bundled architecture with
explicit prompt embeddings (no weights can be downloaded here), run on a rendered frame, and the adapter's
boxes, masks, pixel coordinates and class -> family mapping checked against ultralytics' own output."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.perception import PerceptionError, YoloeDetector, look_at
from bim2rdt.perception.yoloe import import_yoloe, yoloe_prompts

from tests.perception.conftest import CONE, DRUM, placed, render

torch = pytest.importorskip("torch", reason="the yoloe extra is not installed (pip install '.[yoloe]')")
pytest.importorskip("ultralytics", reason="the yoloe extra is not installed (pip install '.[yoloe]')")

ARCHITECTURE = "yoloe-11s-seg.yaml"
FAMILIES = [CONE, DRUM, "Wooden_Crate_1200x800x600"]


@pytest.fixture(scope="module")
def embeddings(tmp_path_factory):
    """Random prompt embeddings for the families' prompts, saved the way users ship them (.npz)."""
    yolo = import_yoloe()(ARCHITECTURE)
    prompts = list(yoloe_prompts(FAMILIES)) + ["a forklift on a construction site"]  # a class no family has
    generator = torch.Generator().manual_seed(0)
    yolo.set_classes(prompts, torch.randn(1, len(prompts), yolo.model.model[-1].embed, generator=generator))
    return yolo.save_prompt_embeddings(tmp_path_factory.mktemp("yoloe") / "prompts.npz")


def test_prompts_are_the_families_in_the_papers_form():
    assert yoloe_prompts(FAMILIES) == {"a traffic cone on a construction site": CONE,
                                       "a steel drum on a construction site": DRUM,
                                       "a wooden crate on a construction site": "Wooden_Crate_1200x800x600"}


def test_the_adapter_reports_ultralytics_boxes_masks_and_classes_as_families(site, embeddings):
    frame, _ = render(site, [placed(CONE, 13.4, 1.9), placed(DRUM, 15.5, 2.5)], look_at((10.5, 1.8, 1.1),
                                                                                        (13.0, 2.3, 0.4)))
    torch.manual_seed(1)  # random weights: the same seed builds the same network twice
    raw = import_yoloe()(ARCHITECTURE)
    raw.load_prompt_embeddings(embeddings)
    bgr = np.ascontiguousarray(frame.rgb[..., ::-1])  # ultralytics reads arrays as OpenCV's BGR
    scores = raw.predict(bgr, imgsz=640, conf=1e-6, device="cpu", retina_masks=True, verbose=False)[0].boxes.conf
    confidence = float(torch.sort(scores, descending=True).values[min(7, len(scores) - 1)]) - 1e-6  # ~8 boxes
    expected = raw.predict(bgr, imgsz=640, conf=confidence, device="cpu", retina_masks=True, verbose=False)[0]

    torch.manual_seed(1)
    detector = YoloeDetector(ARCHITECTURE, embeddings, FAMILIES, confidence=confidence)
    detections = detector.detect(frame)
    _, images, _ = detector.yolo.predictor.batch
    assert np.array_equal(images[0], bgr)  # the frame's RGB went in as the BGR ultralytics expects
    assert len(detections) == len(expected.boxes) > 0
    names = expected.names
    for detection, box, cls, score, mask in zip(detections, expected.boxes.xyxy.numpy(), expected.boxes.cls.numpy(),
                                                expected.boxes.conf.numpy(), expected.masks.data.numpy()):
        u0, v0, u1, v1 = detection.bbox
        assert (u0, v0) == (int(np.floor(max(box[0], 0))), int(np.floor(max(box[1], 0))))
        assert (u1, v1) == (int(np.ceil(min(box[2], 640))), int(np.ceil(min(box[3], 480))))
        assert 0 <= u0 < u1 <= 640 and 0 <= v0 < v1 <= 480  # u runs along the 640 columns, v down the 480 rows
        assert detection.mask.shape == (480, 640) and np.array_equal(detection.mask, mask > 0.5)
        vs, us = np.nonzero(detection.mask)
        if len(us):  # ultralytics crops masks to their box: the mask lies in the bbox, in the same (u, v)
            assert u0 <= us.min() and us.max() < u1 + 1 and v0 <= vs.min() and vs.max() < v1 + 1
        prompt = names[int(cls)]
        assert detection.label == prompt and detection.score == pytest.approx(float(score))
        assert detection.family == yoloe_prompts(FAMILIES).get(prompt, "unknown")
        assert detection.detector == "yoloe"


def test_weights_are_read_from_local_paths_only(tmp_path, embeddings):
    with pytest.raises(PerceptionError, match="no weights file"):
        YoloeDetector(tmp_path / "yoloe-11s-seg.pt", embeddings)  # a name ultralytics would download: refused
    with pytest.raises(PerceptionError, match="prompt embeddings"):
        YoloeDetector(ARCHITECTURE, tmp_path / "missing.npz")
