"""The demo job, on the embedded default site (``make demo``):

1. a simulated site day (:mod:`bim2rdt.demo.site_day`): BIM -> priors -> robot mission with SG-ICP -> twin update ->
   hand-arm vibration monitoring -> IfcEvent/IfcTask records -> ``site_twin.ifc``, with a plan view, an
   exposure plot, ``site_day.json`` and ``report.md``;
2. the paper's four registration scenarios (ICP vs SG-ICP, a few trials) with a before/after plot each, in
   ``registration/``;
3. the settings that ran (``Settings`` with the demo's defaults, :mod:`bim2rdt.demo.settings`: every section,
   secrets masked), seed and versions in ``config.json``;
4. ``report.html``: the self-contained report (plan map, deviations with tolerances, ICP vs SG-ICP, A(8) per
   worker, links to the twin IFC, BCF issues and maps).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.evaluation.runs import RegistrationRun, run_registration_scenarios, save_run, versions
from bim2rdt.demo.site_day import SiteDay, run_site_day

DEMO_TRIALS = 6
DEMO_SEED = 0


@dataclass
class DemoResult:
    site_day: SiteDay
    report: dict[str, Path]
    registration: RegistrationRun
    published: Path | None = None
    """The results bag's folder (``publish``)."""


def run_demo(out_dir: Path, trials: int = DEMO_TRIALS, seed: int = DEMO_SEED, workers: int = 2,
             minutes: float = 60.0, tick: Callable[[str], None] = lambda stage: None, detector: str = "geometric",
             yoloe: tuple[Path, Path] | None = None, record: Path | None = None,
             max_targets: int | None = None, publish: Path | None = None) -> DemoResult:
    """Run the site day and the registration scenarios into ``out_dir`` (created), with the settings read once
    from the environment; the robot reads its frames with ``detector`` (``yoloe``: local weights and prompt
    embeddings). ``config.json`` records those settings (secrets masked), the detector, the seed and the versions.
    ``publish``: also write the results as a ROS 2 bag there (:mod:`bim2rdt.demo.publish`)."""
    from bim2rdt.config import settings_record
    from bim2rdt.demo.progress import write_day_progress
    from bim2rdt.demo.settings import demo_settings
    from bim2rdt.demo.site_report import write_site_report

    out_dir = Path(out_dir)
    settings = demo_settings()
    day = run_site_day(out_dir, seed=seed, workers=workers, minutes=minutes, mission_config=settings.mission,
                       icp=settings.registration, twin_config=settings.twin, tick=tick, detector=detector,
                       yoloe=yoloe, record=record, max_targets=max_targets, keep_odometry=publish is not None,
                       localization=settings.localization, perception=settings.perception,
                       structure_config=settings.structure)
    day.progress = write_day_progress(day, out_dir, settings.progress)
    report = write_site_report(day, out_dir)
    published = None
    if publish is not None:
        from bim2rdt.demo.publish import publish_day

        published = publish_day(publish, day)
    run = run_registration_scenarios(out_dir / "registration", trials, seed, settings.registration, peers=False,
                                     tick=lambda: tick("trial"))
    save_run(run, out_dir / "registration", settings_record(settings))
    resolved = {"settings": settings_record(settings), "trials": trials, "seed": seed, "workers": workers,
                "minutes": minutes, "detector": detector, "yoloe": [str(p) for p in yoloe] if yoloe else None,
                "versions": versions()}
    write_bytes_atomic(out_dir / "config.json", json.dumps(resolved, indent=2).encode("utf-8"))
    report["html"] = _html(day, run, out_dir)
    return DemoResult(day, report, run, published)


def _html(day: SiteDay, run: RegistrationRun, out_dir: Path) -> Path:
    """report.html beside report.md (written last, so it links to every file of the run); closes the day's twin."""
    from bim2rdt.demo.day_html import write_day_html

    try:
        return write_day_html(day, run, out_dir)
    finally:
        day.twin.close()
