"""Run the perception benchmark: every detector on the same frames, timed per stage, scored against the truth.

Times are CPU seconds of this process (``time.process_time``), pinned to one core by the command: what a
frame costs on one core, not how long it waited for a core on a shared machine; wall time is kept beside."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from bim2rdt.bench.perception.frames import BenchFrame
from bim2rdt.bench.perception.scoring import Tally, score_frame
from bim2rdt.bim import BimModel
from bim2rdt.perception import Detection, Detector, Frame, perceive_frame
from bim2rdt.semantics import UprightPrior
from bim2rdt.sim.ideal import IdealDetector


@dataclass
class DetectorRun:
    """One detector over all frames: the tally and the seconds per frame of each stage."""

    name: str
    tally: Tally = field(default_factory=Tally)
    stage_seconds: dict[str, list[float]] = field(default_factory=dict)
    frame_seconds: list[float] = field(default_factory=list)
    wall_seconds: list[float] = field(default_factory=list)

    def record(self, stages: dict[str, float], wall: float) -> None:
        for stage, seconds in stages.items():
            self.stage_seconds.setdefault(stage, []).append(seconds)
        self.frame_seconds.append(sum(stages.values()))
        self.wall_seconds.append(wall)

    def summary(self) -> dict:
        t = self.tally
        return {
            "detector": self.name, "frames": len(self.frame_seconds), "objects": t.required,
            "recall": t.found / t.required if t.required else float("nan"),
            "precision": t.true_positives / (t.true_positives + t.false_positives)
            if t.true_positives + t.false_positives else float("nan"),
            "family_accuracy": t.right_family / t.true_positives if t.true_positives else float("nan"),
            "workers_seen": t.workers_seen, "workers_unknown": t.workers_unknown,
            "false_positives": t.false_positives,
            "translation_m_median": _median(t.translation_m), "translation_m_p90": _p90(t.translation_m),
            "tilt_deg_median": _median(t.tilt_deg), "yaw_deg_median": _median(t.yaw_deg),
            "yaw_deg_p90": _p90(t.yaw_deg), "poses": len(t.translation_m),
            "seconds_per_frame_median": _median(self.frame_seconds),
            "seconds_per_frame_p90": _p90(self.frame_seconds),
            "wall_seconds_per_frame_median": _median(self.wall_seconds),
            "stage_seconds_median": {k: _median(v) for k, v in self.stage_seconds.items()},
            "confusions": dict(sorted(t.confusions.items(), key=lambda kv: -kv[1])),
        }


class _Given:
    """A detector that hands back detections already made (so perceive_frame can be timed without them)."""

    def __init__(self, name: str, detections: list[Detection]) -> None:
        self.name, self.detections = name, detections

    def detect(self, frame: Frame) -> list[Detection]:
        return self.detections


def run_detectors(frames: list[BenchFrame], model: BimModel, priors: dict[str, UprightPrior],
                  detectors: list[Detector], tick: Callable[[], None] = lambda: None) -> list[DetectorRun]:
    """Every detector (plus the ideal one, first) on every frame: detect, perceive, score."""
    runs = {"ideal": DetectorRun("ideal"), **{d.name: DetectorRun(d.name) for d in detectors}}
    for bench_frame in frames:
        families = [t.family for t in bench_frame.reality.truth]
        for detector in [IdealDetector(families).bind(bench_frame.rendered), *detectors]:
            _run_one(runs[detector.name], detector, bench_frame, model, priors)
        tick()
    return list(runs.values())


def _run_one(run: DetectorRun, detector: Detector, bench_frame: BenchFrame, model: BimModel,
             priors: dict[str, UprightPrior]) -> None:
    wall, start = time.perf_counter(), time.process_time()
    detections = detector.detect(bench_frame.frame)
    detect_seconds = time.process_time() - start
    start = time.process_time()
    observations = perceive_frame(bench_frame.frame, model, priors, _Given(detector.name, detections))
    stages = dict(getattr(detector, "timings", {}) or {"detect": detect_seconds})
    stages["points+register"] = time.process_time() - start
    run.record(stages, time.perf_counter() - wall)
    run.tally.add(score_frame(observations, detections, bench_frame.rendered.labels, bench_frame.reality.truth,
                              bench_frame.visible))


def _median(values: list[float]) -> float:
    return float(np.median(values)) if values else float("nan")


def _p90(values: list[float]) -> float:
    return float(np.percentile(values, 90)) if values else float("nan")


TARGETS = {"recall": 0.9, "precision": 0.9, "family_accuracy": 0.95, "translation_m_median": 0.02,
           "tilt_deg_median": 2.0, "yaw_deg_median": 2.0, "seconds_per_frame_median": 0.5}
"""The geometric detector's targets: at least the first three, at most the rest (one core)."""


def check_targets(summary: dict) -> list[tuple[str, bool, str]]:
    """(target, passed, detail) for the geometric detector's summary."""
    out = []
    for key, bound in TARGETS.items():
        value = summary[key]
        at_least = key in ("recall", "precision", "family_accuracy")
        passed = value >= bound if at_least else value <= bound
        out.append((key, bool(passed), f"{value:.4g} {'>=' if at_least else '<='} {bound:g}"))
    return out
