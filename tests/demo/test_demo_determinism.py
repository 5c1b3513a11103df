"""Same seed, same verdicts, on any machine and any thread count. The FZK day runs twice, the way two machines
differ: BLAS threads (1 and 2) and BLAS kernels (this CPU's own, and OpenBLAS's baseline SSE3 "Prescott" one,
which a machine whose CPU OpenBLAS does not recognise falls back to). Their last bits differ; the decisions
(stations, verdicts, what was not seen) must not. A round object's x and y extents once differed in the last bit,
and picked its "long side", and so its station, differently on each. The first run is the session's FZK day
(``fzk_day``, tests/conftest.py: this process, one thread, this CPU's kernel, shared with test_demo_ifc.py); the
other runs in a fresh process on two threads and the Prescott kernel, reading the model cache the first one
filled (as the second of two fresh processes did before)."""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.samples


def decisions_of(day) -> dict:
    """What the day decided: its stations (m, rounded to a millimetre), verdicts, objects not seen, missing
    objects and skipped stations (JSON-ready)."""
    import numpy as np

    return {
        "stations": [np.round(T[:3, 3], 3).tolist() for T in day.route.plan.stations],
        "verdicts": sorted([str(o.global_id), o.family, str(o.status), o.station] for o in day.mission.observations),
        "not_seen": day.mission.not_seen, "missing": sorted(m.global_id for m in day.mission.missing),
        "skipped": sorted(day.route.route.skipped),
    }


DAY = f"""
import json, sys, tempfile
from pathlib import Path
from bim2rdt.demo.ifc_day import run_ifc_day
{inspect.getsource(decisions_of)}
day = run_ifc_day(Path(sys.argv[1]), Path(tempfile.mkdtemp()), workers=1, minutes=float(sys.argv[2]))
print(json.dumps(decisions_of(day)))
"""


def decisions(ifc, minutes: float, threads: int, kernel: str | None, cache) -> dict:
    env = {**os.environ, "OMP_NUM_THREADS": str(threads), "OPENBLAS_NUM_THREADS": str(threads),
           "BIM2RDT_CACHE_DIR": str(cache)}
    env.pop("OPENBLAS_CORETYPE", None)
    if kernel:
        env["OPENBLAS_CORETYPE"] = kernel
    result = subprocess.run([sys.executable, "-c", DAY, str(ifc), repr(minutes)], capture_output=True, text=True,
                            env=env, timeout=900)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_the_fzk_day_decides_the_same_on_one_thread_and_two_and_on_another_blas_kernel(fzk_day):
    assert set(fzk_day.threads.values()) == {1}  # the session's day ran on one thread
    here = json.loads(json.dumps(decisions_of(fzk_day.day)))  # as the other process prints them
    elsewhere = decisions(fzk_day.ifc, fzk_day.minutes, threads=2, kernel="Prescott", cache=fzk_day.cache)
    assert here["verdicts"] and here["not_seen"] == []
    assert elsewhere == here
