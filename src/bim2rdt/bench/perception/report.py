"""One run of the perception benchmark, end to end, as a JSON-ready record (what ran, the results, targets)."""

from __future__ import annotations

import platform
from collections.abc import Callable
from pathlib import Path

import numpy as np

from bim2rdt.bench.perception.flying import flying_pixel_study
from bim2rdt.bench.perception.frames import bench_frames, site_model
from bim2rdt.bench.perception.runs import check_targets, run_detectors
from bim2rdt.bench.perception.yoloe import random_yoloe, seconds_per_frame, yoloe_installed
from bim2rdt.perception import GeometricDetector, YoloeDetector
from bim2rdt.perception.library import library_for
from bim2rdt.registration import IcpConfig
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.reality import UNPLANNED_FAMILY


def run_bench(folder: Path, seeds: list[int], worker_fraction: float, flying_trials: int,
              yoloe: tuple[Path, Path] | None, tick: Callable[[], None] = lambda: None) -> dict:
    """Build the site in ``folder``, render every seed's frames, run and score the detectors, time YOLOE (when
    installed), run the flying-pixel study; returns the record."""
    model = site_model(folder)
    families = sorted(set(library_for(model).families) | {UNPLANNED_FAMILY})
    priors = KnowledgeBasePriors().priors(families)
    frames = list(bench_frames(model, seeds, worker_fraction))
    detectors = [GeometricDetector(model, priors)]
    if yoloe is not None:
        detectors.append(YoloeDetector(yoloe[0], yoloe[1], families))
    runs = run_detectors(frames, model, priors, detectors, tick)
    summaries = [run.summary() for run in runs]
    geometric = next(s for s in summaries if s["detector"] == "geometric")
    ideal = next(s for s in summaries if s["detector"] == "ideal")
    record = {"seeds": seeds, "worker_fraction": worker_fraction, "frames": len(frames),
              "frames_with_workers": sum(f.worker for f in frames), "detectors": summaries,
              "ideal_seconds_per_frame": ideal["seconds_per_frame_median"],
              "geometric_over_ideal_time": geometric["seconds_per_frame_median"] / ideal["seconds_per_frame_median"],
              "targets": check_targets(geometric), "machine": platform.platform()}
    if yoloe is None and yoloe_installed():
        times = seconds_per_frame(random_yoloe(families, folder), [f.frame for f in frames[:10]])
        record["yoloe"] = {"weights": "bundled yoloe-11s-seg.yaml, random", "frames": len(times),
                           "seconds_per_frame_median": float(np.median(times)),
                           "note": "time only: random weights detect nothing meaningful (no pretrained weights "
                                   "here; pass --yoloe-weights/--yoloe-embeddings to score real ones)"}
    if flying_trials > 0:
        record["flying"] = flying_pixel_study(flying_trials, seeds[0], IcpConfig())
    return record
