"""Progress of a long command told by stages (``tick(stage)`` after each step of a stage).

- On a terminal: a live line with the stage, its count (``7/24`` where the total is known), the elapsed time and,
  where the total is known, a bar and the time left.
- Piped or redirected (``make demo | tee log``, CI): plain lines, flushed at once: one when a stage ends (its
  count and time), and in a long stage one every ``HEARTBEAT_S`` seconds, so a log never sits silent for minutes.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

from rich.console import Console

HEARTBEAT_S = 30.0
"""Longest silence of a piped log within one stage, s."""


class StageProgress:
    """``with StageProgress(console, labels, totals) as tick: run(tick=tick)``. ``labels`` name the stages
    (``{"station": "robot station"}``), ``totals`` give the counts known beforehand (``{"trial": 24}``)."""

    def __init__(self, console: Console, labels: Mapping[str, str], totals: Mapping[str, int] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.console, self.labels, self.totals, self.clock = console, dict(labels), dict(totals or {}), clock
        self.stage: str | None = None
        self.count = 0
        self.started = self.last_line = self.stage_began = self.last_tick = clock()
        self._bar = None
        self._task = None

    def __enter__(self) -> Callable[[str], None]:
        self.started = self.last_line = self.stage_began = self.last_tick = self.clock()
        if self.console.is_terminal:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, \
                TimeRemainingColumn

            self._bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                                 TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(),
                                 console=self.console, transient=True)
            self._bar.start()
        return self.tick

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self._end_stage()
        if self._bar is not None:
            self._bar.stop()

    def tick(self, stage: str) -> None:
        """One step of ``stage`` is done."""
        if stage != self.stage:
            self._end_stage()
            self.stage, self.count = stage, 0
            if self._bar is not None:
                self._task = self._bar.add_task(self.label(stage), total=self.totals.get(stage))
        self.count += 1
        self.last_tick = self.clock()
        if self._bar is not None:
            # drawn at each step: steps may come faster than the bar's own 10 Hz refresh
            self._bar.update(self._task, completed=self.count, refresh=True)
        if self.count == self.totals.get(stage):  # all its steps done: say so now, not at the next stage's first
            self._end_stage()
        elif self._bar is None and self.clock() - self.last_line >= HEARTBEAT_S:
            self._line(f"{self.label(stage)}: {self._counted()} so far", self.last_tick)

    def label(self, stage: str) -> str:
        return self.labels.get(stage, stage)

    def _counted(self) -> str:
        total = self.totals.get(self.stage)
        return f"{self.count}/{total}" if total else str(self.count)

    def _end_stage(self) -> None:
        if self.stage is None:
            return
        if self._bar is not None:
            self._bar.remove_task(self._task)
        else:  # a stage runs from the end of the one before to its last step
            took = self.last_tick - self.stage_began
            counted = "" if self.totals.get(self.stage) == 1 else f"{self._counted()} "
            self._line(f"{self.label(self.stage)}: {counted}done in {took:.0f} s", self.last_tick)
        self.stage, self.stage_began = None, self.last_tick

    def _line(self, text: str, at: float) -> None:
        elapsed = at - self.started
        self.console.print(f"[{int(elapsed) // 60:02d}:{int(elapsed) % 60:02d}] {text}", markup=False,
                           highlight=False)
        self.console.file.flush()
        self.last_line = self.clock()
