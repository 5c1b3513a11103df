"""YOLOE in the benchmark. With the user's weights and prompt embeddings it is one more detector, scored like
the others. Without them (no pretrained weights ship here, and none may be downloaded) only its speed means
anything: it is built from the architecture bundled with ultralytics, with random prompt embeddings for the
site's families, and timed on the same frames."""

from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path

from bim2rdt.perception import Frame, YoloeDetector
from bim2rdt.perception.yoloe import import_yoloe, yoloe_prompts

BUNDLED_ARCHITECTURE = "yoloe-11s-seg.yaml"


def yoloe_installed() -> bool:
    try:
        import_yoloe()
    except ImportError:
        return False
    return True


def random_yoloe(families: list[str], folder: Path, seed: int = 0) -> YoloeDetector:
    """YOLOE-11s-seg with random weights and random prompt embeddings for ``families``' prompts, through the
    same adapter and ``.npz`` route as real ones (the embeddings are written to ``folder``)."""
    import torch

    prompts = list(yoloe_prompts(families))
    with contextlib.redirect_stdout(sys.stderr):
        yolo = import_yoloe()(BUNDLED_ARCHITECTURE)
        generator = torch.Generator().manual_seed(seed)
        yolo.set_classes(prompts, torch.randn(1, len(prompts), yolo.model.model[-1].embed, generator=generator))
        path = yolo.save_prompt_embeddings(Path(folder) / "random_prompts.npz")
    return YoloeDetector(BUNDLED_ARCHITECTURE, path, families)


def seconds_per_frame(detector: YoloeDetector, frames: list[Frame]) -> list[float]:
    """CPU seconds of ``detect`` on each frame (after one warm-up call), as the other detectors are timed."""
    if frames:
        detector.detect(frames[0])
    out = []
    for frame in frames:
        start = time.process_time()
        detector.detect(frame)
        out.append(time.process_time() - start)
    return out
