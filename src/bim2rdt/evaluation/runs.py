"""Run the registration scenarios end to end and save what a run produced (shared by the benchmark command and
the demo): the methods, the per-family upright priors, plots, and the resolved config with seeds and versions."""

from __future__ import annotations

import json
import platform
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.registration import IcpConfig
from bim2rdt.evaluation.aliases import ALIAS_FAMILIES, alias_scenario
from bim2rdt.evaluation.checks import TargetCheck
from bim2rdt.evaluation.stats import (COLUMNS, Prior, ScenarioResult, alias_agreement, check_alias_targets,
                                      check_calibration_target, check_family_targets, check_peer_accuracy,
                                      check_targets, cut_interval, improvement, pooled_median_ms, run_scenario,
                                      worst_family)
from bim2rdt.evaluation.peers import Open3dIcp, SgIcp, SmallGicp, small_gicp_available
from bim2rdt.evaluation.plots import plot_before_after
from bim2rdt.sim.families import FAMILIES, family_scenario
from bim2rdt.sim.scenarios import SCENARIOS, scenario


@dataclass
class RegistrationRun:
    """Everything one run produced."""

    config: IcpConfig
    trials: int
    seed: int
    priors: dict[str, Prior]
    results: list[ScenarioResult]
    targets: list[TargetCheck]
    plots: list[Path]
    families: list[ScenarioResult] = field(default_factory=list)  # F1-F11 (sim.families, bench...aliases), when run


def upright_priors(families: Sequence[str]) -> dict[str, Prior]:
    """(upright_bias, yaw_only) per family from the offline knowledge base (bim2rdt.semantics)."""
    from bim2rdt.semantics import KnowledgeBasePriors

    return {family: (prior.upright_bias, prior.yaw_only)
            for family, prior in KnowledgeBasePriors().priors(list(families)).items()}


def build_methods(config: IcpConfig, peers: bool) -> list:
    """ICP and SG-ICP (one loop, with and without the priors), SG-ICP on the upright prior alone (an ablation),
    plus Open3D's two ICPs and small_gicp's PLANE_ICP and GICP (one thread and every usable core; when it is
    installed) when ``peers``."""
    methods = [SgIcp(config, use_prior=False), SgIcp(config, use_prior=True),
               SgIcp(config, use_prior=True, contact=False)]
    if peers:
        methods += [Open3dIcp(config, plane=False), Open3dIcp(config, plane=True)]
        if small_gicp_available():
            methods += [SmallGicp(config, kind, threads) for threads in (1, 0) for kind in ("PLANE_ICP", "GICP")]
    return methods


def run_registration_scenarios(out_dir: Path | None, trials: int, seed: int, config: IcpConfig, peers: bool,
                               names: Sequence[str] = tuple(SCENARIOS), families: Sequence[str] = (),
                               tick: Callable[[], None] = lambda: None) -> RegistrationRun:
    """Build and run each scenario, then each scene family (``families``, e.g. ``tuple(FAMILIES)``); with
    ``out_dir``, save one before/after plot per scenario there."""
    methods = build_methods(config, peers)
    priors = upright_priors([family for name in names for family, *_ in SCENARIOS[name].layout])
    results, plots = [], []
    for name in names:
        built = scenario(name, trials=trials, seed=seed, sample_count=config.sample_count)
        result = run_scenario(built, methods, priors, tick)
        results.append(result)
        if out_dir is not None:
            plots.append(plot_before_after(built, result, Path(out_dir) / f"registration_{name}.png"))
    family_results = [run_family(name, trials, seed, config, peers, tick) for name in families]
    plain = [r for r in family_results if "aliases" not in r.tags]
    aliases = [r for r in family_results if "aliases" in r.tags]
    targets = (check_targets(results) + check_family_targets(plain) + check_alias_targets(aliases)
               + check_peer_accuracy(results, family_results)
               + check_calibration_target(results + family_results))
    return RegistrationRun(config, trials, seed, priors, results, targets, plots, family_results)


def run_family(name: str, trials: int, seed: int, config: IcpConfig, peers: bool,
               tick: Callable[[], None] = lambda: None) -> ScenarioResult:
    """ICP, SG-ICP (and Open3D point-to-plane and small_gicp on one thread with ``peers``) on scene family
    ``name`` (F1-F9: :data:`bim2rdt.sim.families.FAMILIES`; F10-F11, the yaw aliases:
    :data:`bim2rdt.evaluation.aliases.ALIAS_FAMILIES`, with the alias agreement). The family's own
    model density and its user-given upright bias apply, as they would for a user calling ``register``."""
    spec = FAMILIES[name] if name in FAMILIES else ALIAS_FAMILIES[name]
    family_config = config.model_copy(update={"sample_count": spec.sample_count})
    methods = [m for m in build_methods(family_config, peers) if m.name in FAMILY_METHODS]
    priors = {o.family: (spec.upright_bias, False) for o in spec.objects}
    built = (family_scenario if name in FAMILIES else alias_scenario)(name, trials=trials, seed=seed)
    result = run_scenario(built, methods, priors, tick)
    if name in ALIAS_FAMILIES:
        result.alias_agreement = alias_agreement(built, result)
    return result


FAMILY_NAMES = (*FAMILIES, *ALIAS_FAMILIES)
"""Every scene family ``bench registration`` runs after S1-S4."""
FAMILY_METHODS = ("ICP", "SG-ICP", "Open3D pt-plane", "small_gicp plane 1T", "small_gicp GICP 1T")
"""What runs on the scene families: the two methods the families judge, and the peers users would pick (on one
thread: the families judge accuracy; S1-S4 time the peers)."""


def run_record(run: RegistrationRun, settings: dict | None = None) -> dict:
    """The run as plain JSON-able data: the registration config it ran with (and, given, every setting: see
    ``bim2rdt.config.settings_record``), seed, priors, versions, per-scenario stats, targets."""
    return {
        "config": run.config.model_dump(), **({"settings": settings} if settings is not None else {}),
        "trials": run.trials, "seed": run.seed, "versions": versions(),
        "priors": {family: {"upright_bias": bias, "yaw_only": yaw} for family, (bias, yaw) in run.priors.items()},
        "scenarios": {r.name: {"description": r.description,
                               "methods": {m: _no_nan(asdict(s)) for m, s in r.stats.items()},
                               "sg_icp_cut_percent": {metric: {"value": improvement(getattr(r.stats["ICP"], metric),
                                                                                    getattr(r.stats["SG-ICP"], metric)),
                                                               "ci95": list(cut_interval(r, metric))}
                                                      for metric in COLUMNS}}
                      for r in run.results},
        "families": {r.name: {"description": r.description,
                              "methods": {m: _no_nan(asdict(s)) for m, s in r.stats.items()},
                              "sg_icp_cut_percent": {"mean": {"value": improvement(r.stats["ICP"].mean,
                                                                                   r.stats["SG-ICP"].mean),
                                                              "ci95": list(cut_interval(r, "mean"))}},
                              **({"alias_agreement": {"share": r.alias_agreement[0], "count": r.alias_agreement[1]}}
                                 if r.alias_agreement is not None else {})}
                     for r in run.families},
        "speed": speed_record(run.results),
        "worst_family": worst_family(run.families).name if run.families else None,
        "targets": [asdict(t) for t in run.targets],
        "plots": [str(p) for p in run.plots],
    }


def speed_record(results: Sequence[ScenarioResult]) -> dict:
    """Median time per object over S1-S4 (ms) of every method, and SG-ICP's ratio to each (its time / theirs)."""
    methods = [m for m in results[0].stats if all(m in r.stats for r in results)] if results else []
    medians = {m: pooled_median_ms(results, m) for m in methods}
    ours = medians.get("SG-ICP", float("nan"))
    return {"median_ms": medians, "sg_icp_ratio": {m: ours / t for m, t in medians.items() if m != "SG-ICP" and t > 0}}


def _no_nan(record: dict) -> dict:
    """NaN (e.g. no leaning object in a scenario) as null, so results.json is strict JSON."""
    return {key: None if isinstance(value, float) and value != value else value for key, value in record.items()}


def save_run(run: RegistrationRun, out_dir: Path, settings: dict | None = None) -> Path:
    """Write ``results.json`` (see :func:`run_record`) atomically into ``out_dir``."""
    text = json.dumps(run_record(run, settings), indent=2)
    return write_bytes_atomic(Path(out_dir) / "results.json", text.encode("utf-8"))


def versions() -> dict[str, str]:
    """Versions of Python and the packages that shape the numbers."""
    import numpy
    import scipy
    import trimesh

    import bim2rdt

    found = {"python": platform.python_version(), "bim2rdt": bim2rdt.__version__, "numpy": numpy.__version__,
             "scipy": scipy.__version__, "trimesh": trimesh.__version__}
    try:
        import open3d

        found["open3d"] = open3d.__version__
    except ImportError:
        found["open3d"] = "absent"
    try:
        from importlib.metadata import version

        found["small_gicp"] = version("small_gicp")
    except Exception:  # noqa: BLE001 - absent or unreadable metadata: say so
        found["small_gicp"] = "absent"
    return found
