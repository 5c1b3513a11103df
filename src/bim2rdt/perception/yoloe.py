"""YOLOE, the paper's open-vocabulary detector, on local weights (extra ``yoloe``: ``ultralytics-opencv-headless``).

Prompts are the BIM's families in the paper's form ("a traffic cone on a construction site", from
:func:`bim2rdt.semantics.simplify_family`). YOLOE needs a text encoder (MobileCLIP) to turn prompts into
embeddings, and ultralytics fetches it from the network; so the embeddings are computed once where there is
network (``m = YOLOE("yoloe-11s-seg.pt"); m.set_classes(prompts); m.save_prompt_embeddings("site.npz")``) and
shipped as an ``.npz`` beside the ``.pt``. Both are read from local paths only: a weights path that is not a
file is refused before ultralytics could try to download it (only the architecture files bundled with
ultralytics, ``*.yaml``, are accepted by name: random weights, for tests). ``YOLO_OFFLINE`` is set, so
ultralytics makes no network call of its own either.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from bim2rdt.perception.detection import Detection
from bim2rdt.perception.errors import PerceptionError
from bim2rdt.perception.frame import Frame
from bim2rdt.perception.observation import UNKNOWN_FAMILY
from bim2rdt.semantics import detector_prompt, simplify_family


def yoloe_prompts(families: Iterable[str]) -> dict[str, str]:
    """{prompt: family} for BIM families, in the paper's form ("a traffic cone on a construction site"); the
    first family wins where two simplify to the same prompt."""
    prompts: dict[str, str] = {}
    for family in families:
        prompts.setdefault(detector_prompt(simplify_family(family)), family)
    return prompts


class YoloeDetector:
    """YOLOE-seg as a :class:`~bim2rdt.perception.detector.Detector`. ``weights``: a local ``.pt`` (or a bundled
    architecture ``.yaml``); ``prompt_embeddings``: a local ``.npz`` from ``save_prompt_embeddings`` whose class
    names are the prompts; ``families``: the BIM families the prompts stand for (a class whose prompt is none of
    theirs keeps its prompt as label and is "unknown"; without ``families`` perception maps labels to the model's
    families itself).

    Args:
        weights: A local ``.pt`` file (or a bundled architecture ``.yaml``); nothing is downloaded.
        prompt_embeddings: A local ``.npz`` from ``save_prompt_embeddings``; its class names are the prompts.
        families: The BIM families the prompts stand for; None lets perception map labels to families.
        confidence: Lowest score a detection keeps, 0-1.
        image_size: The network's input size, pixels.
        device: The torch device ("cpu", "cuda:0").
    """

    name = "yoloe"

    def __init__(self, weights: str | Path, prompt_embeddings: str | Path, families: Sequence[str] | None = None,
                 confidence: float = 0.25, image_size: int = 640, device: str = "cpu") -> None:
        self.prompts = yoloe_prompts(families or ())
        self.confidence, self.image_size, self.device = confidence, image_size, device
        self.yolo = _load(Path(weights), Path(prompt_embeddings))
        names = self.yolo.model.names
        self.classes = list(names.values()) if isinstance(names, dict) else list(names)

    def detect(self, frame: Frame) -> list[Detection]:
        """Find the prompted objects in one frame's colour image.

        Args:
            frame: An RGB-D frame (only its RGB image is read here).

        Returns:
            One detection per box above ``confidence``, with family (or "unknown"), label, bbox, mask and score.
        """
        result = self.yolo.predict(np.ascontiguousarray(frame.rgb[..., ::-1]), imgsz=self.image_size,
                                   conf=self.confidence, device=self.device, retina_masks=True, verbose=False)[0]
        if result.boxes is None or len(result.boxes) == 0:
            return []
        boxes = result.boxes.xyxy.cpu().numpy()
        classes = result.boxes.cls.cpu().numpy().astype(int)
        scores = result.boxes.conf.cpu().numpy()
        masks = result.masks.data.cpu().numpy() > 0.5 if result.masks is not None else [None] * len(boxes)
        return [self._detection(frame, box, cls, score, mask) for box, cls, score, mask in
                zip(boxes, classes, scores, masks)]

    def _detection(self, frame: Frame, box: np.ndarray, cls: int, score: float, mask) -> Detection:
        prompt = self.classes[cls]
        family = self.prompts.get(prompt, UNKNOWN_FAMILY if self.prompts else prompt)
        width, height = frame.intrinsics.width, frame.intrinsics.height
        bbox = (int(np.floor(max(box[0], 0))), int(np.floor(max(box[1], 0))),
                int(np.ceil(min(box[2], width))), int(np.ceil(min(box[3], height))))
        if mask is not None and mask.shape != (height, width):
            mask = None  # a mask at another resolution would misplace corners; the box alone is the ROI
        return Detection(family, label=prompt, bbox=bbox, mask=mask, score=float(score), detector=self.name)


def import_yoloe():
    """ultralytics' YOLOE class, imported offline (``YOLO_OFFLINE``), its first-run notes sent to stderr so a
    command's JSON on stdout stays clean. ImportError when the extra is not installed."""
    os.environ.setdefault("YOLO_OFFLINE", "1")
    with contextlib.redirect_stdout(sys.stderr):
        from ultralytics import YOLOE
    return YOLOE


def _load(weights: Path, embeddings: Path):
    """YOLOE from local files only, with the prompt embeddings loaded; PerceptionError names what is missing."""
    if weights.suffix == ".pt" and not weights.is_file():
        raise PerceptionError(f"yoloe: no weights file at {weights} (weights are read from local paths only)")
    if weights.suffix not in (".pt", ".yaml"):
        raise PerceptionError(f"yoloe: weights must be a .pt file or a bundled .yaml architecture, got {weights}")
    if embeddings.suffix != ".npz" or not embeddings.is_file():
        raise PerceptionError(f"yoloe: no prompt embeddings file (.npz) at {embeddings}")
    try:
        YOLOE = import_yoloe()
    except ImportError:
        raise PerceptionError("yoloe: ultralytics is not installed; pip install 'bim2rdt[yoloe]'") from None
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yolo = YOLOE(str(weights))
            yolo.load_prompt_embeddings(embeddings)
    except (ValueError, FileNotFoundError, RuntimeError) as error:
        raise PerceptionError(f"yoloe: cannot load {weights.name} with {embeddings.name}: "
                              f"{' '.join(str(error).split())[:200]}") from None
    return yolo
