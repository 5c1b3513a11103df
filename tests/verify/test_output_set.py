"""OutputSet: a run's files are staged inside --out and moved in as one set; names the run did not write go, the
user's own files stay, a failed run changes nothing, and a stop signal during the move lands after it."""

from __future__ import annotations

import os
import signal

import pytest

from bim2rdt.verify import output_set
from bim2rdt.verify.output_set import OutputSet


def _earlier(out):
    out.mkdir()
    for name in ("twin.db", "twin.ifc", "report.html"):
        (out / name).write_text(f"earlier {name}")
    (out / "maps").mkdir()
    (out / "maps" / "site.pgm").write_text("earlier map")
    (out / "notes.txt").write_text("the user's")


def test_a_commit_moves_the_staged_set_in_and_removes_what_this_run_did_not_write(tmp_path):
    out = tmp_path / "verify"
    _earlier(out)
    with OutputSet(out) as run:
        assert run.folder.parent == out and run.folder.name.startswith(".verify-run-")
        for name in ("twin.db", "report.html"):
            (run.folder / name).write_text(f"new {name}")
        assert run.previous() == ["maps", "report.html", "twin.db", "twin.ifc"]
        assert run.commit() == ["report.html", "twin.db"]
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "report.html", "twin.db"]
    assert (out / "twin.db").read_text() == "new twin.db" and (out / "notes.txt").read_text() == "the user's"


def test_a_run_that_fails_leaves_the_earlier_set_and_no_staging_folder(tmp_path):
    out = tmp_path / "verify"
    _earlier(out)
    before = {p.name: p.read_text() for p in out.iterdir() if p.is_file()}
    with pytest.raises(RuntimeError), OutputSet(out) as run:
        (run.folder / "twin.db").write_text("half")
        raise RuntimeError("the run failed")
    assert {p.name: p.read_text() for p in out.iterdir() if p.is_file()} == before
    assert (out / "maps" / "site.pgm").read_text() == "earlier map"


def test_a_stop_signal_during_the_move_is_raised_after_it_with_the_whole_set_in_place(tmp_path, monkeypatch):
    out = tmp_path / "verify"
    _earlier(out)
    seen, moves = [], []
    real_replace = os.replace

    def replace_and_interrupt(source, target):
        if not moves:
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C after the first file of the set is moved
        moves.append(target)
        real_replace(source, target)

    previous = signal.signal(signal.SIGINT, lambda signum, frame: seen.append(len(moves)))
    try:
        monkeypatch.setattr(output_set.os, "replace", replace_and_interrupt)
        with OutputSet(out) as run:
            for name in ("twin.db", "twin.json", "report.html"):
                (run.folder / name).write_text("new")
            run.commit()
    finally:
        signal.signal(signal.SIGINT, previous)
    assert seen == [3]  # delivered once, after all three moves
    assert all((out / name).read_text() == "new" for name in ("twin.db", "twin.json", "report.html"))


def test_a_staging_folder_of_a_killed_run_goes_and_a_live_ones_stays(tmp_path):
    dead, alive = tmp_path / ".verify-run-999999999-aaaaaa", tmp_path / f".verify-run-{os.getpid()}-bbbbbb"
    dead.mkdir()
    alive.mkdir()
    assert output_set.remove_abandoned(tmp_path) == [dead]
    assert alive.is_dir() and not dead.exists()
