"""Dump every row a HAV monitor stores for a fixed bench-like input, to check that a change stores the same bytes.

``bench hav``'s signals for ``STREAMS`` wearables (and one idle signal) go through a monitor for 7 one-second
rounds. In round 3 one stream has a knock, one a NaN sample, and one batch is missing. Every row of ``streams``
(the state text as stored, and decoded), ``days``, ``applied``, ``activities``, ``events`` (without the receive
time, which is the wall clock) and ``raw`` is written to ``OUT`` as text (blobs as their SHA-1), then every event.
Run it on two trees and compare the files (decisions 0047 and 0051)::

    PYTHONPATH=<main>/src python scripts/hav_rows_dump.py /tmp/main.txt 400
    PYTHONPATH=<branch>/src python scripts/hav_rows_dump.py /tmp/branch.txt 400
    cmp /tmp/main.txt /tmp/branch.txt
"""

import hashlib
import json
import sqlite3
import sys
import tempfile
from pathlib import Path

import numpy as np

from bim2rdt.bench.hav import DISTINCT_SIGNALS, TOOLS
from bim2rdt.bus import AccelBatch
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.safety.monitor import HavMonitor
from bim2rdt.safety.statecodec import decode_state
from bim2rdt.sim.vibration import WEARABLE_RANGE, tool_vibration

ROUNDS, FS, T0 = 7, 5000.0, 1.7e9
TABLES = ("streams", "days", "applied", "activities", "events", "raw")


def round_batches(signals: list[np.ndarray], streams: int, r: int) -> list[AccelBatch]:
    """Round ``r``'s batches; round 3 has a knock (d1), a NaN sample (d2) and no batch from d3."""
    n = int(FS)

    def batch(i: int, xyz: np.ndarray) -> AccelBatch:
        return AccelBatch(f"d{i}", r, T0 + r, FS, xyz, WEARABLE_RANGE, T0 + r + 1.02)

    batches = [batch(i, signals[i % len(signals)][r * n:(r + 1) * n]) for i in range(streams)]
    if r == 3:
        knock, gap = batches[1].xyz.copy(), batches[2].xyz.copy()
        knock[100] = 400.0
        gap[200, 1] = np.nan
        batches[1], batches[2] = batch(1, knock), batch(2, gap)
        del batches[3]
    return batches


def main(out: str, streams: int) -> None:
    """Run the rounds and write the dump."""
    signals = [tool_vibration(TOOLS[k % 3], ROUNDS + 1, FS, seed=k) for k in range(DISTINCT_SIGNALS)]
    signals.append(tool_vibration("idle", ROUNDS + 1, FS, seed=99))
    events = []
    with tempfile.TemporaryDirectory(prefix="bim2rdt-rows-") as folder:
        monitor = HavMonitor(Path(folder), "bench", [], MonitorConfig(raw_retention_s=0.0))
        for r in range(ROUNDS):
            events += monitor.ingest_many(round_batches(signals, streams, r), now=T0 + r + 1.02)
        commits = monitor.store.commits
        monitor.close()
        db = sqlite3.connect(Path(folder) / "hav.sqlite")
        with open(out, "w") as handle:
            for table in TABLES:
                for row in db.execute(f"SELECT * FROM {table} ORDER BY 1, 2"):
                    row = row[:-1] if table == "events" else row
                    if table == "streams":
                        row = (row[0], row[1], json.dumps(decode_state(row[1])), row[2])
                    values = [hashlib.sha1(v).hexdigest() if isinstance(v, bytes) else v for v in row]
                    handle.write(f"{table} {values!r}\n")
            for e in events:
                handle.write(f"event {(e.kind, e.time, e.subject, e.source, json.dumps(e.data, sort_keys=True))!r}\n")
        db.close()
    print(f"{commits} commits for {ROUNDS} rounds, {len(events)} events")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 400)
