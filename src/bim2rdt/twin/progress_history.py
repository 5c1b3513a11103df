"""Progress over time from the twin's history: the products' states at any past date are ``twin.state(at)``, so
the observed percentage at each date, each task's actual start and finish, and an S-curve of planned against
observed come from the same computation as the progress at one date.

The structure's judgements (walls, slabs, columns: ``structure.json``) are merged over the twin's object verdicts
from the time they were made on.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from typing import TYPE_CHECKING

from bim2rdt.bim import Quantities, WorkSchedule
from bim2rdt.twin.progress import ScheduleProgress, merge_statuses, schedule_progress, with_actuals
from bim2rdt.twin.records import MISSING, OBSERVATION, ElementState

StatusesAt = Callable[[datetime], Mapping[str, str]]
"""date -> {GlobalId: status}: the products' states as they were known at that date."""

if TYPE_CHECKING:
    from bim2rdt.twin.twin import DigitalTwin


@dataclass(frozen=True)
class CurvePoint:
    """The whole schedule at one date: planned and observed percentage (0-100; observed None after the last
    observation's date, or when nothing was observed)."""

    date: datetime
    planned_percent: float | None
    observed_percent: float | None


def twin_statuses(states: Mapping[str, ElementState]) -> dict[str, str]:
    """The verdicts of the BIM's elements in a twin state.

    Args:
        states: ``twin.state(...)``.

    Returns:
        {GlobalId: status value} of the elements the BIM has (objects it lacks build no task).
    """
    return {global_id: state.status.value for global_id, state in states.items() if state.in_bim}


def twin_statuses_at(twin: DigitalTwin, structure: Mapping[str, str] | None = None,
                     structure_time: datetime | None = None) -> StatusesAt:
    """The products' states at any date: the twin's verdicts then, with ``structure`` merged over them from
    ``structure_time`` on (always, when it is None).

    Args:
        twin: A ``DigitalTwin``.
        structure: {GlobalId: structure status} ("as planned", "deviating", "not built", "not observed").
        structure_time: When the structure was judged, UTC; None: at every date.

    Returns:
        date -> {GlobalId: status}.
    """
    def statuses(at: datetime) -> Mapping[str, str]:
        objects = twin_statuses(twin.state(at=at.timestamp()))
        if structure and (structure_time is None or at >= structure_time):
            return merge_statuses(objects, structure)
        return merge_statuses(objects)

    return statuses


def observation_times(twin: DigitalTwin) -> list[datetime]:
    """When the twin's history observed something (observations and places seen empty), UTC, oldest first.

    Args:
        twin: A ``DigitalTwin``.

    Returns:
        The distinct times.
    """
    times = {event.time for event in twin.events(kinds=[OBSERVATION, MISSING])}
    return [datetime.fromtimestamp(t, timezone.utc) for t in sorted(times)]


def curve_dates(schedule: WorkSchedule, observed: Iterable[datetime], now: datetime) -> list[datetime]:
    """The dates of an S-curve: every day from the schedule's first start to its last finish, each observation
    time, and ``now``.

    Args:
        schedule: The work schedule.
        observed: Observation times, UTC.
        now: The progress date, UTC.

    Returns:
        Sorted distinct dates.
    """
    starts = [t.schedule_start for t in schedule.tasks if t.schedule_start is not None]
    finishes = [t.schedule_finish for t in schedule.tasks if t.schedule_finish is not None]
    dates = {now, *observed}
    if starts and finishes:
        day, last = min(starts), max(finishes)
        while day <= last:
            dates.add(day)
            day += timedelta(days=1)
        dates.add(last)
    return sorted(dates)


def progress_over_time(schedule: WorkSchedule, quantities: Quantities, statuses_at: StatusesAt, now: datetime,
                       dates: Iterable[datetime], behind_percent: float = 10.0,
                       ahead_percent: float = 10.0) -> tuple[ScheduleProgress, list[CurvePoint]]:
    """The schedule's progress at ``now`` with each task's actual start and finish, and its S-curve.

    Args:
        schedule: The work schedule.
        quantities: The products' quantities.
        statuses_at: The products' states at a date.
        now: The progress date, UTC.
        dates: The curve's dates (see :func:`curve_dates`); observed only up to ``now``.
        behind_percent: Percentage points under planned beyond which a task is behind.
        ahead_percent: Percentage points over planned beyond which a task is ahead.

    Returns:
        (progress at ``now`` with actuals, the curve's points).
    """
    def at(date: datetime) -> ScheduleProgress:
        return schedule_progress(schedule, statuses_at(date), quantities, date, behind_percent, ahead_percent)

    past = [at(date) for date in dates if date < now]
    current = at(now)
    planned_only = [schedule_progress(schedule, {}, quantities, date) for date in dates if date > now]
    curve = [CurvePoint(p.date, p.planned_percent, p.observed_percent) for p in [*past, current]]
    curve += [CurvePoint(p.date, p.planned_percent, None) for p in planned_only]
    return with_actuals(current, past), curve
