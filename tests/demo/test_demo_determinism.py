"""Same seed, same verdicts, on any machine and any thread count. The FZK day runs in two fresh processes that
differ the way two machines do: BLAS threads (1 and 2) and BLAS kernels (this CPU's own, and OpenBLAS's
baseline SSE3 "Prescott" one, which a machine whose CPU OpenBLAS does not recognise falls back to). Their last
bits differ; the decisions (stations, verdicts, what was not seen) must not. A round object's x and y extents
once differed in the last bit, and picked its "long side", and so its station, differently on each."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.samples

DAY = """
import json, sys, tempfile
from pathlib import Path
import numpy as np
from bim2rdt.demo.ifc_day import run_ifc_day
day = run_ifc_day(Path(sys.argv[1]), Path(tempfile.mkdtemp()), workers=1, minutes=1.0)
print(json.dumps({
    "stations": [np.round(T[:3, 3], 3).tolist() for T in day.route.plan.stations],
    "verdicts": sorted([str(o.global_id), o.family, str(o.status), o.station] for o in day.mission.observations),
    "not_seen": day.mission.not_seen, "missing": sorted(m.global_id for m in day.mission.missing),
    "skipped": sorted(day.route.route.skipped),
}))
"""


def decisions(ifc, threads: int, kernel: str | None) -> dict:
    env = {**os.environ, "OMP_NUM_THREADS": str(threads), "OPENBLAS_NUM_THREADS": str(threads)}
    env.pop("OPENBLAS_CORETYPE", None)
    if kernel:
        env["OPENBLAS_CORETYPE"] = kernel
    result = subprocess.run([sys.executable, "-c", DAY, str(ifc)], capture_output=True, text=True, env=env,
                            timeout=900)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_the_fzk_day_decides_the_same_on_one_thread_and_two_and_on_another_blas_kernel(samples):
    ifc = samples / "AC20-FZK-Haus.ifc"
    here = decisions(ifc, threads=1, kernel=None)
    elsewhere = decisions(ifc, threads=2, kernel="Prescott")
    assert here["verdicts"] and here["not_seen"] == []
    assert elsewhere == here
