"""The demo's day runs once per `make test`: under ``--dist loadfile`` the files that take it from the session's
``demo_run`` fixture are one unit of work for one xdist worker; every other file stays a unit of its own."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import SimpleNamespace

ROOT = Path(__file__).resolve().parents[1]


def _root_conftest():
    """tests/conftest.py by its path (``import conftest`` gets whichever conftest pytest imported last)."""
    spec = importlib.util.spec_from_file_location("root_conftest", ROOT / "tests" / "conftest.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_CONFTEST = _root_conftest()
DEMO_DAY_MODULES, SERIAL_MODULES = _CONFTEST.DEMO_DAY_MODULES, _CONFTEST.SERIAL_MODULES
OFFICE1_VERIFY_MODULES, LONG_UNITS = _CONFTEST.OFFICE1_VERIFY_MODULES, _CONFTEST.LONG_UNITS
FZK_DAY_MODULES = _CONFTEST.FZK_DAY_MODULES
pytest_xdist_make_scheduler = _CONFTEST.pytest_xdist_make_scheduler


def _config(dist: str) -> SimpleNamespace:
    return SimpleNamespace(getvalue={"dist": dist, "tx": ["2*popen"]}.get)


def test_the_demo_day_files_are_one_unit_and_the_others_one_each():
    schedule = pytest_xdist_make_scheduler(_config("loadfile"), None)
    assert {schedule._split_scope(f"{name}::test_x") for name in DEMO_DAY_MODULES} == {DEMO_DAY_MODULES[0]}
    other = "tests/demo/test_record_round_trip.py"
    assert schedule._split_scope(f"{other}::test_y") == other
    assert schedule._split_scope("tests/bench/test_perception_office.py::test_z[a::b]") == \
        "tests/bench/test_perception_office.py"


def test_the_office1_verify_files_are_one_unit_apart_from_the_demo_days():
    schedule = pytest_xdist_make_scheduler(_config("loadfile"), None)
    scopes = {schedule._split_scope(f"{name}::test_x[a::b]") for name in OFFICE1_VERIFY_MODULES}
    assert scopes == {OFFICE1_VERIFY_MODULES[0]} != {DEMO_DAY_MODULES[0]}
    other = "tests/verify/test_office1_judge.py"
    assert schedule._split_scope(f"{other}::test_y") == other


def test_the_fzk_day_files_are_one_unit_apart_from_the_other_groups():
    schedule = pytest_xdist_make_scheduler(_config("loadfile"), None)
    scopes = {schedule._split_scope(f"{name}::test_x[a::b]") for name in FZK_DAY_MODULES}
    assert scopes == {FZK_DAY_MODULES[0]} and not scopes & {DEMO_DAY_MODULES[0], OFFICE1_VERIFY_MODULES[0]}
    other = "tests/demo/test_demo_every_ifc.py"
    assert schedule._split_scope(f"{other}::test_y[AC20-FZK-Haus.ifc]") == other


class _Node:
    """A worker as the scheduler sees it: it is sent the indexes of the tests to run."""

    def send_runtest_some(self, indexes) -> None:
        pass


def test_the_long_units_are_handed_out_first_in_their_order_and_the_rest_in_xdists():
    schedule = pytest_xdist_make_scheduler(_config("loadfile"), None)
    rest = ["tests/a/test_many.py", "tests/a/test_some.py"]  # xdist's order: by number of tests
    for scope in [*rest[:1], *reversed(LONG_UNITS), *rest[1:]]:
        schedule.workqueue[scope] = {f"{scope}::test_x": False}
    sent, node = [], _Node()
    schedule.registered_collections[node] = [nodeid for unit in schedule.workqueue.values() for nodeid in unit]
    while schedule.workqueue:
        schedule._assign_work_unit(node)
        sent += list(schedule.assigned_work[node])[len(sent):]
    assert sent == [*LONG_UNITS, *rest]


def test_other_dist_modes_keep_xdists_scheduler():
    assert pytest_xdist_make_scheduler(_config("load"), None) is None


def test_each_listed_file_exists_and_runs_in_the_parallel_part():
    listed = DEMO_DAY_MODULES + OFFICE1_VERIFY_MODULES + FZK_DAY_MODULES
    assert all((ROOT / name).is_file() for name in listed)  # a renamed file would leave the unit
    assert not set(listed) & set(SERIAL_MODULES) and len(set(listed)) == len(listed)
    shared = [name for unit in _CONFTEST.SHARED_RUN_UNITS for name in unit[1:]]
    assert all((ROOT / name).is_file() for name in LONG_UNITS) and len(set(LONG_UNITS)) == len(LONG_UNITS)
    assert not set(LONG_UNITS) & (set(SERIAL_MODULES) | set(shared))  # a group is named by its first file
