"""Where each round of ``bench hav``'s throughput loop goes: thread CPU time per stage of the monitor, round by round.

The loop is the bench's (:func:`bim2rdt.bench.hav.run_throughput`: the floor, then the monitor, on the same batches
each round; the batches laid out as decoded payloads, the floor's rows C-ordered) for ``ROUNDS`` timed rounds, with
thread-time wrappers around the monitor's stages, so a round that drifts shows which stage grew. Per round: the
floor's and the monitor's seconds, each stage's milliseconds (a wrapper's time includes what it calls: ``push``
holds ``weigh_round``, which holds the rest but ``commit`` and ``_track``), and the monitor's minor page faults
and involuntary context switches. Decision 0055::

    taskset -c 1 env PYTHONPATH=src OMP_NUM_THREADS=1 python scripts/hav_round_stages.py 12
"""

import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.signal

import bim2rdt.safety.engine as engine
import bim2rdt.safety.persistence as persistence
import bim2rdt.safety.weighing as weighing
from bim2rdt.bench.hav import DISTINCT_SIGNALS, TOOLS, _as_decoded, _rows
from bim2rdt.bus import AccelBatch
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.safety.filters import design_weighting
from bim2rdt.safety.monitor import HavMonitor
from bim2rdt.sim.vibration import WEARABLE_RANGE, tool_vibration

STREAMS, FS, T0 = 2000, 5000.0, 1.7e9
STAGES = ((weighing, "_stack"), (weighing, "block_moments"), (weighing, "weigh_rows"), (weighing, "block_sums"),
          (weighing, "block_flags"), (engine, "weigh_round"), (engine.ExposureEngine, "_track"),
          (engine.ExposureEngine, "push"), (persistence.MonitorJournal, "commit"))
spent: dict[str, float] = {}


def timed(owner, name: str) -> None:
    """Replace ``owner.name`` by a wrapper that adds its thread time to ``spent[name]``."""
    inner = getattr(owner, name)

    def wrapper(*args, **kwargs):
        start = time.thread_time()
        try:
            return inner(*args, **kwargs)
        finally:
            spent[name] = spent.get(name, 0.0) + time.thread_time() - start

    setattr(owner, name, wrapper)


def main(rounds: int) -> None:
    """Print one line per timed round."""
    for owner, name in STAGES:
        timed(owner, name)
    n = int(FS)
    signals = [_as_decoded(tool_vibration(TOOLS[k % 3], 7, FS, seed=k)) for k in range(DISTINCT_SIGNALS)]
    sos = design_weighting(FS).sos
    zi = np.zeros((sos.shape[0], 3 * STREAMS, 2))
    names = [name for _, name in STAGES]
    print("round floor_s monitor_s ratio | " + " ".join(names) + " (ms) | minflt nivcsw")
    with tempfile.TemporaryDirectory() as folder:
        monitor = HavMonitor(Path(folder), "bench", [], MonitorConfig(raw_retention_s=0.0))
        for r in range(rounds + 1):
            part = (r % 6) * n  # the bench's 7 s of signal, its 6 timed seconds again and again
            batch = [AccelBatch(f"d{i}", r, T0 + r, FS, signals[i % DISTINCT_SIGNALS][part:part + n], WEARABLE_RANGE,
                                T0 + r + 1.02) for i in range(STREAMS)]
            stacked = _rows(batch)
            start = time.thread_time()
            _, zi = scipy.signal.sosfilt(sos, stacked, axis=-1, zi=zi)
            floor = time.thread_time() - start
            spent.clear()
            before = resource.getrusage(resource.RUSAGE_THREAD)
            start = time.thread_time()
            monitor.ingest_many(batch, now=T0 + r + 1.02)
            ours = time.thread_time() - start
            after = resource.getrusage(resource.RUSAGE_THREAD)
            if r > 0:
                print(f"{r:3d} {floor:.3f} {ours:.3f} {ours / floor:.2f} | "
                      + " ".join(f"{spent.get(name, 0.0) * 1e3:.1f}" for name in names)
                      + f" | {after.ru_minflt - before.ru_minflt} {after.ru_nivcsw - before.ru_nivcsw}", flush=True)
        monitor.close()


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 12)
