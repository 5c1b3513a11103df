"""Shared fixtures: where the real IFC samples are, a per-test cache folder, and the PostgreSQL server of the
session (the twin's and the exposure store's tests)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from bim2rdt.cli.threads import limit_threads

# The numerical pools (BLAS, OpenMP) on one thread in the test processes, as the CLI runs them (decision 0048):
# set before any of them loads, here and in the xdist workers, which inherit the environment. In-process runs
# (the demo's day, office1's verify, the FZK day) spent about twice the CPU on two-thread pools. A variable the
# environment already sets is kept.
limit_threads()

_DEFAULT_SAMPLES = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "ifc"
_DEFAULT_SENSORS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "sensors"


def samples_dir() -> Path:
    """The folder of real IFC files: $BIM2RDT_SAMPLES, else ../shared/data/ifc beside the checkout."""
    return Path(os.environ.get("BIM2RDT_SAMPLES", _DEFAULT_SAMPLES))


SERIAL_MODULES = (
    "tests/bus/test_nats_live.py",  # 60 wearables, 3 monitor processes, a partition back within 10 s
    "tests/bus/test_bench_scale.py",  # the scale bench: processes and latency
    "tests/bus/test_nats_supervisor.py",  # a supervisor, its monitors and a kill -9
    "tests/bus/test_nats_monitor.py",  # redeliveries after an ack wait of 1-2 s
    "tests/bus/test_monitor_acks.py",  # a monitor killed within its 10 s group-commit delay
    "tests/bus/test_nats_last_delivery.py",  # monitor lives of an ack wait of 1 s each
    "tests/server/test_connections.py",  # answers within 2 s under 1,000 connections
    "tests/safety/test_outbox.py",  # a feed within 5 s
    "tests/cli/test_interrupt.py",  # Ctrl-C at a given moment of a run
    "tests/cli/test_verify_progress.py",  # the live bar's time-left estimate
)
"""Test files `make test` runs alone after the parallel part (marker ``serial``): their deadlines assume the
machine is not shared with the other worker."""


DEMO_DAY_MODULES = (
    "tests/demo/test_demo.py",  # what the demo writes and prints
    "tests/demo/test_demo_route.py",  # the robot's walk on the demo's day
)
"""Test files that take the demo's day from the session's one run (the ``demo_run`` fixture). `make test` sends
them to one xdist worker as one unit (``pytest_xdist_make_scheduler`` below), so the day runs once there."""

OFFICE1_VERIFY_MODULES = (
    "tests/cli/test_verify.py",  # the pose, the furniture's verdicts
    "tests/cli/test_verify_structure.py",  # the walls' and the slab's judgements
    "tests/cli/test_verify_bag.py",  # the frame as a bag verifies as the frame does
)
"""Test files that take office1's corrected verify from the session's one run (the ``office1_verified`` fixture),
sent to one xdist worker as one unit as :data:`DEMO_DAY_MODULES` are."""

FZK_DAY_MODULES = (
    "tests/demo/test_demo_ifc.py",  # the house's day: its site objects, its walk, its verdicts
    "tests/demo/test_demo_determinism.py",  # the same decisions on another thread count and BLAS kernel
)
"""Test files that take the FZK house's day from the session's one run (the ``fzk_day`` fixture), sent to one
xdist worker as one unit as :data:`DEMO_DAY_MODULES` are."""

SHARED_RUN_UNITS = (DEMO_DAY_MODULES, OFFICE1_VERIFY_MODULES, FZK_DAY_MODULES)
"""Groups of test files that share a session fixture's run: each group is one unit of work under ``loadfile``."""

LONG_UNITS = (
    DEMO_DAY_MODULES[0],
    "tests/safety/test_cli_hav.py",
    "tests/semantics/test_cli_priors.py",
    "tests/demo/test_demo_every_ifc.py",
    "tests/cli/test_bench_localization.py",
    OFFICE1_VERIFY_MODULES[0],
    FZK_DAY_MODULES[0],
    "tests/bim/test_cli_info.py",
    "tests/server/test_cli_server.py",
    "tests/cli/test_bench_registration.py",
    "tests/demo/test_record_round_trip.py",
    "tests/bus/test_broker.py",
    "tests/cli/test_bench_perception.py",
    "tests/cli/test_verify_outputs.py",
    "tests/planning/test_cli_planning.py",
    "tests/cli/test_output_paths.py",
    "tests/demo/test_demo_localization.py",
    "tests/bim/test_integrity.py",
    "tests/bim/test_map_classes.py",
    "tests/test_config.py",
    "tests/bim/test_model.py",
    "tests/sim/test_scenarios.py",
)
"""The longest units of work (a group by its first file), longest first: every unit of about 25 s or more in CI
(decision 0048's amendment: a run of the parallel part under load, its failed tests' time left out). Under
``loadfile`` they are handed out before the others, so the parallel part does not end on one worker still busy
with one of them while the others have nothing left. (xdist's own order is by number of tests: a long file of
one or two tests, as bench perception, would start among the last.)"""


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` with the files of each group of :data:`SHARED_RUN_UNITS` as one unit of work: one
    worker runs them all, so the session's ``demo_run`` (an in-process day, kept in memory), ``office1_verified``
    or ``fzk_day`` is computed once for all of them; the units of :data:`LONG_UNITS` are handed out first.
    Any other ``--dist`` mode: xdist's own scheduler."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class SharedDemoDay(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            scope = super()._split_scope(nodeid)
            return next((unit[0] for unit in SHARED_RUN_UNITS if scope in unit), scope)

        def _assign_work_unit(self, node) -> None:
            for scope in reversed(LONG_UNITS):  # the queue's next unit is the longest one still waiting
                if scope in self.workqueue:
                    self.workqueue.move_to_end(scope, last=False)
            super()._assign_work_unit(node)

    return SharedDemoDay(config, log)


def pytest_collection_modifyitems(config, items) -> None:
    root = Path(__file__).resolve().parents[1]
    for item in items:
        if Path(item.fspath).resolve().relative_to(root).as_posix() in SERIAL_MODULES:
            item.add_marker(pytest.mark.serial)


@pytest.fixture(scope="session")
def samples() -> Path:
    folder = samples_dir()
    if not folder.is_dir():
        pytest.skip(f"IFC samples folder {folder} is absent (set BIM2RDT_SAMPLES to the shared data/ifc folder)")
    return folder


def sensors_dir() -> Path:
    """The folder of real sensor recordings: $BIM2RDT_SENSORS, else ../shared/data/sensors beside the checkout."""
    return Path(os.environ.get("BIM2RDT_SENSORS", _DEFAULT_SENSORS))


@pytest.fixture(scope="session")
def sensors() -> Path:
    folder = sensors_dir()
    if not (folder / "SOURCES.md").is_file():
        pytest.skip(f"sensor data folder {folder} is absent (set BIM2RDT_SENSORS to the shared data/sensors folder)")
    return folder


@pytest.fixture(scope="session")
def office1(sensors):
    """The real office1 Kinect frame (pcl/office1.pcd, depth corrected as its truth file says), its as-built IFC
    and its truth: ``model`` (BimModel), ``frame`` (Frame; its depth read-only), ``truth`` (dict) and
    ``T_world_camera`` (4, 4). Read once per session; skipped with a reason where ../shared/data/sensors is
    absent. Read-only: copy before changing anything."""
    import json
    from types import SimpleNamespace

    import numpy as np

    from bim2rdt.bim import load_ifc
    from bim2rdt.sources import open_source

    folder = sensors / "pcl"
    truth = json.loads((folder / "office1_truth.json").read_text())
    frame = next(iter(open_source(folder / "office1.pcd", depth_correction=truth["depth_correction"]["g"])))
    frame.depth.flags.writeable = False
    return SimpleNamespace(model=load_ifc(folder / "office1.ifc"), frame=frame, truth=truth,
                           T_world_camera=np.array(truth["T_world_camera"]))


def office1_prior(truth: dict) -> str:
    """``--prior`` X,Y,Z,YAW_DEG (m, deg) of office1's truth camera moved 20 cm (14 cm along x and y) and turned
    5 degrees."""
    import math

    T = truth["T_world_camera"]
    yaw = math.degrees(math.atan2(T[1][2], T[0][2])) + 5.0
    return f"{T[0][3] + 0.14},{T[1][3] + 0.14},{T[2][3]},{yaw}"


@pytest.fixture(scope="session")
def office1_verified(sensors, tmp_path_factory):
    """`bim2rdt verify office1.ifc office1.pcd --json --prior P --depth-correction G` (P: :func:`office1_prior`,
    G: the truth file's correction), run in this process once per session: ``truth`` (dict), ``out`` (its
    folder), ``summary`` (its --json output, parsed) and ``prior``, ``g`` (the options given). Shared by the
    files of :data:`OFFICE1_VERIFY_MODULES`: read-only, copy a file before changing it."""
    import json
    from types import SimpleNamespace

    from typer.testing import CliRunner

    from bim2rdt.cli import app
    from bim2rdt.config import get_settings

    folder = sensors / "pcl"
    truth = json.loads((folder / "office1_truth.json").read_text())
    prior, g = office1_prior(truth), ",".join(str(v) for v in truth["depth_correction"]["g"])
    out = tmp_path_factory.mktemp("office1-verify")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("BIM2RDT_CACHE_DIR", str(tmp_path_factory.mktemp("office1-cache")))
        get_settings.cache_clear()
        try:
            result = CliRunner().invoke(app, ["verify", str(folder / "office1.ifc"), str(folder / "office1.pcd"),
                                              "--out", str(out), "--json", "--prior", prior,
                                              "--depth-correction", g])
        finally:
            get_settings.cache_clear()
    assert result.exit_code == 0, (result.output, result.exception)
    return SimpleNamespace(truth=truth, out=out, summary=json.loads(result.output), prior=prior, g=g)


@pytest.fixture(scope="session")
def site_ifc(tmp_path_factory):
    """The default construction site as an IFC4 file (read-only for tests: copy it before writing)."""
    from bim2rdt.sim.site import build_site_ifc

    return build_site_ifc(tmp_path_factory.mktemp("site") / "site.ifc")


@pytest.fixture(scope="session")
def site_model(site_ifc, tmp_path_factory):
    """The embedded site read once per session (geometry included), with its own cache folder."""
    from bim2rdt.bim import load_ifc

    return load_ifc(site_ifc, cache_dir=tmp_path_factory.mktemp("site-cache"))


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory):
    """`bim2rdt demo --trials 1 --workers 1 --minutes 40`, run in this process once per session (the command
    itself, through typer's runner): ``out`` (its folder), ``stdout`` (what it printed) and ``result`` (the
    :class:`~bim2rdt.demo.run.DemoResult` it made; ``day`` is its site day, whose twin the run has closed). Shared
    by the files of :data:`DEMO_DAY_MODULES`: read-only, copy a file before changing it."""
    from types import SimpleNamespace

    from typer.testing import CliRunner

    import bim2rdt.demo.run
    from bim2rdt.cli import app
    from bim2rdt.config import get_settings

    out, made = tmp_path_factory.mktemp("demo"), []
    run_demo = bim2rdt.demo.run.run_demo

    def kept(*args, **kwargs):
        made.append(run_demo(*args, **kwargs))
        return made[-1]

    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("BIM2RDT_CACHE_DIR", str(tmp_path_factory.mktemp("demo-cache")))
        patch.setenv("YOLO_CONFIG_DIR", str(tmp_path_factory.mktemp("demo-yolo")))
        patch.setattr(bim2rdt.demo.run, "run_demo", kept)  # the command imports it when it runs
        get_settings.cache_clear()
        try:
            result = CliRunner().invoke(app, ["demo", "--out", str(out), "--trials", "1", "--workers", "1",
                                              "--minutes", "40"])
        finally:
            get_settings.cache_clear()
    assert result.exit_code == 0 and len(made) == 1, (result.output, result.exception)
    return SimpleNamespace(out=out, stdout=result.stdout, result=made[0], day=made[0].site_day)


@pytest.fixture(scope="session")
def fzk_day(samples, tmp_path_factory):
    """`run_ifc_day(AC20-FZK-Haus.ifc, out, workers=1, minutes=1.0)`, run in this process once per session, its
    numerical pools (BLAS, OpenMP) on one thread as the CLI runs them, with a cache folder of its own: ``day``
    (the :class:`~bim2rdt.demo.site_day.SiteDay`), ``out`` (its folder), ``ifc`` (the house's file), ``minutes``,
    ``threads`` (each pool's number of threads while it ran) and ``cache`` (the model cache it filled). Shared by
    the files of :data:`FZK_DAY_MODULES`: read-only."""
    from types import SimpleNamespace

    from threadpoolctl import threadpool_info, threadpool_limits

    from bim2rdt.config import get_settings
    from bim2rdt.demo.ifc_day import run_ifc_day  # its pools are loaded before they are limited

    ifc, out, minutes = samples / "AC20-FZK-Haus.ifc", tmp_path_factory.mktemp("fzk-day"), 1.0
    cache = tmp_path_factory.mktemp("fzk-cache")
    with pytest.MonkeyPatch.context() as patch, threadpool_limits(limits=1):
        patch.setenv("BIM2RDT_CACHE_DIR", str(cache))
        get_settings.cache_clear()
        try:
            day = run_ifc_day(ifc, out, workers=1, minutes=minutes)
            threads = {pool["internal_api"]: pool["num_threads"] for pool in threadpool_info()}
        finally:
            get_settings.cache_clear()
    return SimpleNamespace(day=day, out=out, ifc=ifc, minutes=minutes, threads=threads, cache=cache)


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory, monkeypatch):
    """Every test gets its own cache folder so caches never leak between tests or into $HOME."""
    monkeypatch.setenv("BIM2RDT_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    monkeypatch.setenv("YOLO_CONFIG_DIR", str(tmp_path_factory.mktemp("yolo")))
    from bim2rdt.config import get_settings

    get_settings.cache_clear()
    yield
    get_settings.cache_clear()


@pytest.fixture(scope="session")
def postgres_admin_url():
    """The PostgreSQL server of the session: CI's (its URL in $BIM2RDT_TEST_POSTGRES_URL), else a private one.
    In CI a missing server fails the suite: these tests are never silently skipped there."""
    from postgres_server import ENV_URL, pg_bindir, private_cluster

    if url := os.environ.get(ENV_URL):
        yield url
        return
    bindir = pg_bindir()
    if bindir is None:
        message = f"no PostgreSQL: set {ENV_URL} or install Debian's postgresql (.ci/run does)"
        pytest.fail(message) if os.environ.get("CI") else pytest.skip(message)
    with private_cluster(bindir) as url:
        yield url
