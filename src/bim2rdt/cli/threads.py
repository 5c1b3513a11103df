"""The thread pools the CLI runs with, set once at start (before numpy, SciPy or Open3D load).

The work is many small matrices (ICP steps of a few hundred points, 3x3 and 4x4 algebra, per-frame depth): BLAS
and OpenMP threads there cost more in hand-offs than they win, and with the default (one thread per core in every
pool) a 2-core machine spent 3x the CPU and 2.5x the wall time on ``make demo``. So each pool gets one thread
unless the user's environment sets its own: ``OMP_NUM_THREADS=4 bim2rdt demo`` still runs four.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                    "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
"""The variables the numerical libraries read for their pool sizes (OpenMP, OpenBLAS, MKL, BLIS, Accelerate,
numexpr)."""

DEFAULT_THREADS = "1"


def limit_threads(environ: MutableMapping[str, str] = os.environ) -> dict[str, str]:
    """Give every pool the CLI's default where the user set none (a value they set, even empty, is kept);
    returns the settings made. Libraries read these when they load, so this runs before any numerical import."""
    made = {name: DEFAULT_THREADS for name in THREAD_VARIABLES if name not in environ}
    environ.update(made)
    return made
