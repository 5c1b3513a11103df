"""The CLI sets its thread pools once at start: one thread per numerical pool (small matrices: BLAS threads cost
3x the CPU on a 2-core machine), unless the user's environment sets a pool's size, which is kept."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from bim2rdt.cli.threads import THREAD_VARIABLES, limit_threads

PROBE = """
import atexit, json, sys
def pools():
    import numpy, threadpoolctl  # loaded after the CLI's start, as every command's heavy imports are
    numpy.ones((64, 64)) @ numpy.ones((64, 64))
    print(json.dumps({p["internal_api"]: p["num_threads"] for p in threadpoolctl.threadpool_info()}))
atexit.register(pools)
sys.argv = ["bim2rdt", "--version"]
from bim2rdt.cli import main
main()
"""


def pools_of_the_cli(**environ: str) -> dict[str, int]:
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES} | environ
    result = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_the_cli_runs_blas_on_one_thread_by_default():
    assert os.cpu_count() > 1  # else one thread is every library's default, and this shows nothing
    assert pools_of_the_cli()["openblas"] == 1


def test_a_pool_size_the_user_sets_is_kept():
    assert pools_of_the_cli(OPENBLAS_NUM_THREADS="2")["openblas"] == 2


def test_limit_threads_fills_only_what_the_environment_leaves_unset():
    environ = {"OMP_NUM_THREADS": "3"}
    made = limit_threads(environ)
    assert environ["OMP_NUM_THREADS"] == "3" and "OMP_NUM_THREADS" not in made
    assert environ["OPENBLAS_NUM_THREADS"] == "1" and made["OPENBLAS_NUM_THREADS"] == "1"


def test_the_test_processes_run_blas_as_the_cli_does():
    """tests/conftest.py gives this process the CLI's pools: in-process runs cost what the command costs."""
    import numpy
    import threadpoolctl

    numpy.ones((64, 64)) @ numpy.ones((64, 64))
    pools = {p["internal_api"]: p["num_threads"] for p in threadpoolctl.threadpool_info()}
    assert pools["openblas"] == int(os.environ["OPENBLAS_NUM_THREADS"])  # 1 unless the environment says
