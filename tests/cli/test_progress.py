"""Progress by stages: on a terminal a live line with counts, elapsed time and time left; piped, plain lines as
stages end (and a heartbeat in a long stage), flushed at once, so `make demo | tee log` is never silent."""

from __future__ import annotations

import io

from rich.console import Console

from bim2rdt.cli.progress import HEARTBEAT_S, StageProgress

LABELS = {"bim": "site model read", "station": "robot station", "trial": "registration trial"}


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_piped_output_gets_one_plain_line_per_stage_with_its_count_and_time():
    out, clock = io.StringIO(), Clock()
    console = Console(file=out, force_terminal=False, width=140)
    with StageProgress(console, LABELS, {"bim": 1, "trial": 24}, clock=clock) as tick:
        clock.now = 2.0
        tick("bim")
        assert out.getvalue() == "[00:02] site model read: done in 2 s\n"  # a stage with all its steps: at once
        for _ in range(3):
            clock.now += 5.0
            tick("station")
        clock.now += 4.0
        tick("trial")
        tick("trial")
        assert out.getvalue().count("\n") == 2  # a stage of unknown length ends with the next one's first step
    assert out.getvalue().splitlines() == ["[00:02] site model read: done in 2 s",
                                           "[00:17] robot station: 3 done in 15 s",
                                           "[00:21] registration trial: 2/24 done in 4 s"]


def test_a_long_stage_piped_says_how_far_it_is_every_so_often():
    out, clock = io.StringIO(), Clock()
    console = Console(file=out, force_terminal=False, width=140)
    with StageProgress(console, LABELS, clock=clock) as tick:
        tick("station")
        clock.now = HEARTBEAT_S + 1.0
        tick("station")
        clock.now += 1.0
        tick("station")
    lines = out.getvalue().splitlines()
    assert lines == ["[00:31] robot station: 2 so far", "[00:32] robot station: 3 done in 32 s"]


def test_on_a_terminal_the_live_line_has_the_count_of_a_known_total_and_time_left():
    console = Console(file=io.StringIO(), force_terminal=True, width=120)
    progress = StageProgress(console, LABELS, {"trial": 24})
    with progress as tick:
        for _ in range(7):
            tick("trial")
        task = progress._bar.tasks[-1]
        assert (task.description, task.completed, task.total) == ("registration trial", 7, 24)
        columns = [type(c).__name__ for c in progress._bar.columns]
        assert "MofNCompleteColumn" in columns and "TimeRemainingColumn" in columns
