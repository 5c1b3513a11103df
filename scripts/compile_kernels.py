"""Compile (or load from numba's cache) every compiled kernel once, before the test suite's parallel workers start.

Each kernel is cached next to its module on first use (``cache=True``); on a fresh checkout that first compile costs
tens of seconds of one core. ``make test`` runs this first, so no test with a deadline pays it, and the workers do not
each compile the same kernels at once.
"""

from bim2rdt.registration import load_kernels
from bim2rdt.safety.iir import compile_kernels
from bim2rdt.verify.shift_search import load_kernels as load_plan_search_kernels


def main() -> None:
    """Compile the registration's, the plan search's and the HAV monitor's kernels."""
    load_kernels()
    load_plan_search_kernels()
    compile_kernels()


if __name__ == "__main__":
    main()
