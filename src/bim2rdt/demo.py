"""The demo job. For now: the paper's four registration scenarios (ICP vs SG-ICP, few trials, well under a
minute), a before/after plot per scenario, results and the resolved config/seed/versions saved in ``out_dir``.
The full site loop (BIM, perception, twin, safety) will extend :func:`run_demo`."""

from __future__ import annotations

import json
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.sim.registration_runs import RegistrationRun, run_registration_scenarios, save_run, versions

DEMO_TRIALS = 6
DEMO_SEED = 0


def run_demo(out_dir: Path, trials: int = DEMO_TRIALS, seed: int = DEMO_SEED, tick=lambda: None) -> RegistrationRun:
    """Run the registration scenarios into ``out_dir`` (created): plots, results.json and config.json."""
    from bim2rdt.config import get_settings

    out_dir = Path(out_dir)
    config = get_settings().registration
    run = run_registration_scenarios(out_dir, trials, seed, config, peers=False, tick=tick)
    save_run(run, out_dir)
    resolved = {"registration": config.model_dump(), "trials": trials, "seed": seed, "versions": versions()}
    write_bytes_atomic(out_dir / "config.json", json.dumps(resolved, indent=2).encode("utf-8"))
    return run
