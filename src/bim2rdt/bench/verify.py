"""``bim2rdt bench verify``: seconds per frame of ``verify`` by stage, peak memory, and frames per second against
the source's own rate, on real recordings and the demo's bag.

Cases (each in a fresh process, so its peak resident memory is its own; the process inherits the bench's CPU
pinning):

- ``office1``: the Kinect v1 frame of an office against its as-built IFC, from the test's prior (the truth pose
  moved 20 cm and turned 5 degrees) with the truth file's depth correction;
- ``grabber``: PCL's three ImageGrabber Kinect frames, and ``tum``: the TUM RGB-D frame. Neither has a BIM of
  its own: both are verified against office1.ifc from office1's prior, so their fix is refused and the stages a
  refused frame runs are timed (localize, and the depth check at the best rigid fit);
- ``bag``: the demo's robot's run as a ROS 2 bag (``demo --record``: stations for every one of the site's 10
  objects of interest), verified against the demo's site.ifc, and ``bag-xN``: the same bag played N times in a
  row as one source (the site has no more objects to station the robot at; a run N times as long is what shows
  whether memory stays flat as the run grows).

Stages per frame: ``read`` (the source's next frame), ``localize``, ``depth check``, ``objects`` (planned and
new, :mod:`bim2rdt.verify.timing` hooks); per run: ``setup`` (the occlusion map and the compiled kernels'
one-off load: :func:`bim2rdt.registration.load_kernels`, the plan search's), ``twin`` (recording the twin) and
``outputs``
(twin.json, IFC, BCF, report), shown divided by the frames. Wall and process CPU seconds are
both kept; on a shared machine the targets are judged on CPU seconds (the time this process ran, not the time
others held the core).
"""

from __future__ import annotations

import json
import math
import multiprocessing
import resource
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

FRAME_STAGES = ("read", "localize", "depth check", "objects")
RUN_STAGES = ("setup", "twin", "outputs")
OFFICE_TARGET_S = 0.5
"""Target CPU seconds per frame for office1 on one core."""
VGA_TARGET_S = 1.0
"""Target CPU seconds per frame for any 640x480 frame."""
MEMORY_GROWTH_LIMIT = 1.25
"""Memory counts as flat when the larger bag's peak is at most this multiple of the smaller's."""


@dataclass(frozen=True)
class Case:
    """One recording to verify: the BIM, the source, the prior (4x4 T_world_sensor, or None to trust the
    recording's poses), the depth correction g (1/m) or None, and a note on what the case shows."""

    name: str
    ifc: Path
    source: Path
    prior: list | None = None
    correction: list | None = None
    note: str = ""
    nominal_hz: float | None = None
    """The sensor's frame rate when the recording holds a single frame (Kinect v1: 30 Hz)."""
    repeat: int = 1
    """Play the source this many times in a row as one run."""


@dataclass
class CaseRun:
    """What one case measured: per-frame stage seconds (wall and CPU), per-run stage seconds, frames (and how
    many were localized), the source's frame rate, peak resident memory (MB)."""

    name: str
    note: str
    frames: int = 0
    accepted: int = 0
    per_frame_wall: dict = field(default_factory=dict)
    per_frame_cpu: dict = field(default_factory=dict)
    per_run_wall: dict = field(default_factory=dict)
    per_run_cpu: dict = field(default_factory=dict)
    pixels: list | None = None
    source_hz: float | None = None
    peak_mb: float = 0.0
    error: str | None = None


def office_cases(sensors: Path) -> list[Case]:
    """office1, the grabber frames and the TUM frame, when ``sensors`` holds them (see the module's note)."""
    folder = Path(sensors) / "pcl"
    truth_file = folder / "office1_truth.json"
    if not truth_file.exists():
        return []
    truth = json.loads(truth_file.read_text())
    prior = _office_prior(np.asarray(truth["T_world_camera"], dtype=float)).tolist()
    ifc = folder / "office1.ifc"
    cases = [Case("office1", ifc, folder / "office1.pcd", prior, list(truth["depth_correction"]["g"]),
                  "Kinect v1 office frame on its as-built IFC", nominal_hz=30.0)]
    if (folder / "grabber").is_dir():
        cases.append(Case("grabber", ifc, folder / "grabber", prior, None,
                          "3 Kinect frames, no BIM of their own: against office1.ifc (fix refused)"))
    if (Path(sensors) / "tum").is_dir():
        cases.append(Case("tum", ifc, Path(sensors) / "tum", prior, None,
                          "TUM RGB-D frame, no BIM of its own: against office1.ifc (fix refused)", nominal_hz=30.0))
    return cases


def _office_prior(T_truth: np.ndarray) -> np.ndarray:
    """The truth camera moved 14 cm along x and y and turned 5 degrees about z (verify's own test's prior)."""
    from bim2rdt.verify import prior_pose

    yaw = math.degrees(math.atan2(T_truth[1, 2], T_truth[0, 2])) + 5.0
    return prior_pose((T_truth[0, 3] + 0.14, T_truth[1, 3] + 0.14, T_truth[2, 3]), yaw)


def demo_bags(folder: Path, repeat: int, make_bag: Callable[[Path], None] | None = None) -> list[Case]:
    """The demo's robot run recorded as a ROS 2 bag in ``folder`` (``folder``/run/run.mcap with the demo's
    site.ifc beside it), as it is and played ``repeat`` times in a row; ``make_bag(folder)`` records it when it is
    not there yet (the CLI passes the demo's day: ``bench`` does not import ``demo``)."""
    bag = folder / "run"
    if not (bag / "run.mcap").exists():
        if make_bag is None:
            raise FileNotFoundError(f"no demo bag in {folder} (run/run.mcap and site.ifc)")
        make_bag(folder)
    once = Case("bag", folder / "site.ifc", bag, note="the demo's bag (a station per site object) on its site.ifc")
    return [once, Case(f"bag-x{repeat}", once.ifc, bag, repeat=repeat,
                       note=f"the demo's bag played {repeat} times in a row as one run")]


class _Repeated:
    """A source played ``times`` times in a row (what it dropped and warned about: the last play's)."""

    def __init__(self, frames, times: int) -> None:
        self._frames, self._times = frames, times

    def __iter__(self) -> Iterator:
        for _ in range(self._times):
            yield from self._frames

    def __getattr__(self, name: str):
        return getattr(self._frames, name)


class _TimedFrames:
    """A source whose iteration is timed: ``pending`` holds the wall and CPU seconds spent reading the frame
    handed out last, until the caller takes it."""

    def __init__(self, frames) -> None:
        self._frames = frames
        self.pending = (0.0, 0.0)
        self.times: list[float] = []
        self.pixels: list | None = None

    def __iter__(self) -> Iterator:
        iterator = iter(self._frames)
        while True:
            start, cpu = time.perf_counter(), time.process_time()
            try:
                frame = next(iterator)
            except StopIteration:
                return
            self.pending = (time.perf_counter() - start, time.process_time() - cpu)
            when = getattr(frame, "time", None)
            if when is not None:
                self.times.append(float(when))
            depth = getattr(frame, "depth", None)
            if depth is not None and self.pixels is None:
                self.pixels = [int(depth.shape[1]), int(depth.shape[0])]
            yield frame

    def __getattr__(self, name: str):  # dropped, drop_kind, warnings: the source's own
        return getattr(self._frames, name)


def run_case(case: Case, out: Path) -> CaseRun:
    """Verify ``case`` in this process with the stage hooks on; see the module's note."""
    from bim2rdt.bim import load_ifc
    from bim2rdt.config import get_settings, ifc_cache_dir
    from bim2rdt.sources import open_source
    from bim2rdt.verify import VerifyConfig, record_twin, verify_frames, write_outputs
    from bim2rdt.verify.timing import listening

    settings = get_settings()
    run = CaseRun(case.name, case.note)
    model = load_ifc(case.ifc, cache_dir=ifc_cache_dir(settings))
    options = {"depth_correction": tuple(case.correction)} if case.correction is not None else {}
    source = open_source(case.source, **options)
    frames = _TimedFrames(_Repeated(source, case.repeat) if case.repeat > 1 else source)
    wall, cpu = defaultdict(list), defaultdict(list)
    current_wall, current_cpu = defaultdict(float), defaultdict(float)
    run_wall, run_cpu = defaultdict(float), defaultdict(float)

    def heard(stage: str, wall_s: float, cpu_s: float) -> None:
        target_wall, target_cpu = (run_wall, run_cpu) if stage in RUN_STAGES else (current_wall, current_cpu)
        target_wall[stage] += wall_s
        target_cpu[stage] += cpu_s

    def frame_done(_result) -> None:
        current_wall["read"], current_cpu["read"] = frames.pending
        for stage in FRAME_STAGES:
            wall[stage].append(current_wall.pop(stage, 0.0))
            cpu[stage].append(current_cpu.pop(stage, 0.0))

    config = VerifyConfig(min_fitness=settings.twin.min_fitness)
    with listening(heard):
        result = verify_frames(frames, model, None if case.prior is None else np.asarray(case.prior), config,
                               progress=frame_done)
    start, cpu0 = time.perf_counter(), time.process_time()
    with record_twin(result, model, out, settings.twin) as twin:
        run_wall["twin"], run_cpu["twin"] = time.perf_counter() - start, time.process_time() - cpu0
        start, cpu0 = time.perf_counter(), time.process_time()
        write_outputs(result, twin, out)
        run_wall["outputs"], run_cpu["outputs"] = time.perf_counter() - start, time.process_time() - cpu0
    run.frames, run.accepted = len(result.frames), sum(f.accepted for f in result.frames)
    run.per_frame_wall = {s: float(np.mean(wall[s])) for s in FRAME_STAGES}
    run.per_frame_cpu = {s: float(np.mean(cpu[s])) for s in FRAME_STAGES}
    run.per_run_wall, run.per_run_cpu = dict(run_wall), dict(run_cpu)
    run.pixels = frames.pixels
    run.source_hz = _rate(frames.times) or case.nominal_hz
    run.peak_mb = peak_memory_mb()
    return run


def peak_memory_mb() -> float:
    """This process's peak resident memory, MB: Linux's ``VmHWM`` (the high-water mark of this process image; a
    spawned case starts afresh), else ``ru_maxrss``. ``ru_maxrss`` alone carries the parent's resident size at
    the fork into a spawned child: a bench that made the demo's bag first (~1 GB) read that for every case."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _rate(times: list[float]) -> float | None:
    """Frames per second of a recording from its frame times (the median gap), or None with fewer than two."""
    gaps = np.diff(np.sort(np.asarray(times)))
    gaps = gaps[gaps > 0]
    return float(1.0 / np.median(gaps)) if len(gaps) else None


def _run_in_child(case: Case, out: str, queue) -> None:
    try:
        queue.put(asdict(run_case(case, Path(out))))
    except Exception as error:  # reported in the case's row, the other cases still run
        queue.put(asdict(CaseRun(case.name, case.note, error=f"{type(error).__name__}: {error}")))


def run_isolated(case: Case, out: Path) -> CaseRun:
    """:func:`run_case` in a fresh (spawned) process, so that its peak memory is its own."""
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=_run_in_child, args=(case, str(out), queue))
    child.start()
    record = queue.get()
    child.join()
    return CaseRun(**record)


def summarise(run: CaseRun) -> dict:
    """A case's record: seconds per frame by stage (CPU and wall; per-run stages divided by the frames), the total,
    frames per second and its ratio to the source's rate, peak memory, the target and whether it holds. The total
    and the target are the per-frame stages' (what grows with a run); with the per-run stages too it is shown
    apart (a one-frame run pays its whole twin and report)."""
    if run.error:
        return {"case": run.name, "note": run.note, "error": run.error}
    frames = max(run.frames, 1)
    cpu = {**run.per_frame_cpu, **{s: run.per_run_cpu.get(s, 0.0) / frames for s in RUN_STAGES}}
    wall = {**run.per_frame_wall, **{s: run.per_run_wall.get(s, 0.0) / frames for s in RUN_STAGES}}
    per_frame = sum(cpu[s] for s in FRAME_STAGES)
    target = OFFICE_TARGET_S if run.name == "office1" else VGA_TARGET_S if run.pixels == [640, 480] else None
    fps = 1.0 / per_frame if per_frame > 0 else None
    return {"case": run.name, "note": run.note, "frames": run.frames, "localized": run.accepted,
            "pixels": run.pixels, "cpu_s_per_frame": {k: round(v, 4) for k, v in cpu.items()},
            "wall_s_per_frame": {k: round(v, 4) for k, v in wall.items()},
            "cpu_s_per_frame_total": round(per_frame, 3),
            "wall_s_per_frame_total": round(sum(wall[s] for s in FRAME_STAGES), 3),
            "cpu_s_per_frame_with_run_stages": round(sum(cpu.values()), 3),
            "fps": None if fps is None else round(fps, 3),
            "source_hz": None if run.source_hz is None else round(run.source_hz, 2),
            "fps_vs_source": None if fps is None or not run.source_hz else round(fps / run.source_hz, 4),
            "peak_mb": round(run.peak_mb, 1), "target_s": target,
            "passed": None if target is None else per_frame <= target}


def memory_flat(rows: list[dict]) -> dict | None:
    """Peak memory of the shortest and longest bag cases, and whether it stayed flat
    (:data:`MEMORY_GROWTH_LIMIT`); None with fewer than two bag cases."""
    bags = sorted((r for r in rows if r["case"].startswith("bag") and "error" not in r), key=lambda r: r["frames"])
    if len(bags) < 2:
        return None
    small, large = bags[0], bags[-1]
    ratio = large["peak_mb"] / small["peak_mb"]
    return {"small": small["case"], "small_frames": small["frames"], "small_peak_mb": small["peak_mb"],
            "large": large["case"], "large_frames": large["frames"], "large_peak_mb": large["peak_mb"],
            "ratio": round(ratio, 3), "passed": ratio <= MEMORY_GROWTH_LIMIT}


def run_bench(sensors: Path, repeat: int = 4, bag_dir: Path | None = None,
              cases: tuple[str, ...] | None = None, make_bag: Callable[[Path], None] | None = None) -> dict:
    """Every case (see the module's note), each in its own process; ``repeat``: how many times the long bag case
    plays the demo's bag (in ``bag_dir``, made there by ``make_bag`` when absent and kept for the next run; a
    temporary folder when None); ``cases``: only these."""
    import os

    with tempfile.TemporaryDirectory() as scratch:
        bags_root = Path(bag_dir) if bag_dir is not None else Path(scratch) / "bags"
        todo = office_cases(sensors)
        if cases is None or any(name.startswith("bag") for name in cases):
            todo += demo_bags(bags_root, repeat, make_bag)
        todo = [c for c in todo if cases is None or c.name in cases]
        rows = [summarise(run_isolated(case, Path(scratch) / "out" / case.name)) for case in todo]
    load = os.getloadavg()
    return {"cases": rows, "memory": memory_flat(rows), "load_average": [round(x, 2) for x in load],
            "cpu": sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
            "targets": {"office1_s": OFFICE_TARGET_S, "vga_s": VGA_TARGET_S,
                        "memory_growth": MEMORY_GROWTH_LIMIT}}
