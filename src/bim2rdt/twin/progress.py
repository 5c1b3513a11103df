"""Progress against the 4-D schedule: per task, at a date, how much was planned and how much is observed built.

- **planned %**: the task's IfcTaskTime Completion where the file sets it, else linear over its scheduled dates
  (0 before ScheduleStart, 100 after ScheduleFinish);
- **observed %**: the built quantity of the task's products over their total quantity (``bim.quantities``:
  IfcElementQuantity, else the mesh's volume or area);
- **status**: unknown (none of its products observed), behind (even the products not observed could not make up
  a gap of more than ``behind_percent`` points), ahead (observed over planned by more than ``ahead_percent``),
  complete, not started, or in progress.

The products' states are a plain mapping ``{GlobalId: status}``: the structure's judgements ("as planned",
"deviating", "not built", "not observed") and the twin's object verdicts, where "as planned" and "deviating" are
built, "missing" is not built and anything else is not observed. A partly built element's state is a
:class:`PartlyBuilt` ("deviating", with the share of it built, from structure.json's ``built_share``): its quantity
counts built by that share. Summary tasks roll up their children: the union
of their products, and the children's planned percentages weighted by the children's quantities.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from datetime import datetime
from enum import Enum

from bim2rdt.bim import Quantities, ScheduledTask, WorkSchedule

AS_PLANNED, DEVIATING, NOT_BUILT, NOT_OBSERVED = "as planned", "deviating", "not built", "not observed"
PRODUCT_STATES = (AS_PLANNED, DEVIATING, NOT_BUILT, NOT_OBSERVED)
"""The states a product of a task is counted in (progress.json's ``products``)."""
BUILT = frozenset({AS_PLANNED, DEVIATING})
FULL = 100.0 - 1e-6


class PartlyBuilt(str):
    """A built state ("deviating" or "as planned") that carries ``built``, the share of the element built (0-1):
    a wall built on a third of its face counts a third of its quantity. Compares, hashes and prints as its status.

    Args:
        status: The state, one of :data:`BUILT`.
        built: The share built, 0-1.
    """

    built: float

    def __new__(cls, status: str, built: float) -> PartlyBuilt:
        if status not in BUILT or not 0.0 <= built <= 1.0:
            raise ValueError(f"a partly built state is 'as planned' or 'deviating' with a share 0-1, got {status!r}, "
                             f"{built!r}")
        state = super().__new__(cls, status)
        state.built = float(built)
        return state


def built_share(state: str | None) -> float:
    """How much of a product a state counts built: 0 unless built, a :class:`PartlyBuilt`'s share, else 1.

    Args:
        state: A product state (see :func:`product_state`), or None.

    Returns:
        The share, 0-1.
    """
    if state not in BUILT:
        return 0.0
    return state.built if isinstance(state, PartlyBuilt) else 1.0


class TaskStatus(str, Enum):
    """Where a task stands at a date (the value is what reports print)."""

    NOT_STARTED = "not started"
    IN_PROGRESS = "in progress"
    COMPLETE = "complete"
    BEHIND = "behind"
    AHEAD = "ahead"
    UNKNOWN = "unknown"


def product_state(status: str | None) -> str:
    """A product's state for progress from a structure judgement or a twin verdict.

    Args:
        status: "as planned", "deviating", "not built", "missing", or anything else (None: never judged).

    Returns:
        One of :data:`PRODUCT_STATES` ("missing" counts as "not built"; anything unknown as "not observed").
    """
    if status == "missing":
        return NOT_BUILT
    return status if status in PRODUCT_STATES else NOT_OBSERVED


def merge_statuses(*mappings: Mapping[str, str]) -> dict[str, str]:
    """Several sources of product states in one: a later source wins where it says something (a product it
    leaves "not observed" keeps what an earlier source said).

    Args:
        mappings: {GlobalId: status} each, earliest first.

    Returns:
        {GlobalId: product state}.
    """
    merged: dict[str, str] = {}
    for mapping in mappings:
        for global_id, status in mapping.items():
            state = product_state(status)
            if state != NOT_OBSERVED or global_id not in merged:
                merged[global_id] = state
    return merged


@dataclass(frozen=True)
class TaskProgress:
    """One task at a date: percentages 0-100 (None where there is nothing to say), its status, its products
    counted by state, its built and total quantity (the schedule's quantity kind), when it was first seen
    started and complete (UTC; None until then or when unknown), and the GlobalIds of the products it counted
    (its own and its nested tasks')."""

    task: ScheduledTask
    planned_percent: float | None
    observed_percent: float | None
    status: TaskStatus
    products: dict[str, int]
    built_quantity: float
    total_quantity: float
    actual_start: datetime | None = None
    actual_finish: datetime | None = None
    product_ids: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """The task as progress.json writes it.

        Returns:
            {global_id, name, identification, planned_start, planned_finish (ISO 8601), planned_percent,
                observed_percent, status, products: {state: count}, children: [GlobalId]}.
        """
        task = self.task
        return {"global_id": task.global_id, "name": task.name, "identification": task.identification,
                "planned_start": _iso(task.schedule_start), "planned_finish": _iso(task.schedule_finish),
                "planned_percent": _rounded(self.planned_percent), "observed_percent": _rounded(self.observed_percent),
                "status": self.status.value, "products": dict(self.products), "children": list(task.children)}


@dataclass(frozen=True)
class ScheduleProgress:
    """Every task of a schedule at ``date`` (UTC), in the schedule's order; ``planned_percent`` and
    ``observed_percent`` are the whole schedule's (its root tasks rolled up)."""

    schedule: WorkSchedule
    date: datetime
    tasks: tuple[TaskProgress, ...]
    quantity_kind: str
    planned_percent: float | None
    observed_percent: float | None

    def task(self, global_id: str) -> TaskProgress:
        """One task's progress.

        Args:
            global_id: The IfcTask's GlobalId.

        Returns:
            Its progress.

        Raises:
            KeyError: The schedule has no such task.
        """
        for task in self.tasks:
            if task.task.global_id == global_id:
                return task
        raise KeyError(f"the schedule has no task {global_id}")

    def to_dict(self) -> dict:
        """progress.json.

        Returns:
            {"schedule": {global_id, name}, "date": ISO 8601, "tasks": [task dicts]}.
        """
        return {"schedule": {"global_id": self.schedule.global_id, "name": self.schedule.name},
                "date": _iso(self.date), "tasks": [task.to_dict() for task in self.tasks]}


def schedule_progress(schedule: WorkSchedule, statuses: Mapping[str, str], quantities: Quantities, at: datetime,
                      behind_percent: float = 10.0, ahead_percent: float = 10.0) -> ScheduleProgress:
    """Every task's planned and observed percentage and status at ``at``.

    Args:
        schedule: The work schedule.
        statuses: {GlobalId: status} of the products (see :func:`product_state`); absent ones are not observed.
        quantities: The products' quantities (one kind).
        at: The date, timezone-aware.
        behind_percent: Percentage points observed under planned beyond which a task is behind.
        ahead_percent: Percentage points observed over planned beyond which a task is ahead.

    Returns:
        The schedule's progress.
    """
    states = {global_id: product_state(status) for global_id, status in statuses.items()}
    done: dict[str, TaskProgress] = {}

    def visit(task: ScheduledTask) -> TaskProgress:
        if task.global_id not in done:
            children = [visit(schedule.task(child)) for child in task.children]
            done[task.global_id] = _task_progress(task, children, states, quantities, at, behind_percent,
                                                  ahead_percent)
        return done[task.global_id]

    for task in schedule.tasks:
        visit(task)
    roots = [done[task.global_id] for task in schedule.roots]
    products = _all_products(schedule, [task.task for task in roots])
    built, total, unobserved = _quantities(products, states, quantities)
    observed = 100.0 * built / total if total > 0 and unobserved < total else None
    return ScheduleProgress(schedule, at, tuple(done[task.global_id] for task in schedule.tasks), quantities.kind,
                            _weighted(roots, None), observed)


def _task_progress(task: ScheduledTask, children: list[TaskProgress], states: Mapping[str, str],
                   quantities: Quantities, at: datetime, behind: float, ahead: float) -> TaskProgress:
    products = list(dict.fromkeys(list(task.products) + [p for child in children for p in child.product_ids]))
    built, total, unobserved = _quantities(products, states, quantities)
    counts = {state: 0 for state in PRODUCT_STATES}
    for global_id in products:
        counts[states.get(global_id, NOT_OBSERVED)] += 1
    seen = len(products) - counts[NOT_OBSERVED]
    observed = 100.0 * built / total if seen and total > 0 else None
    planned = _weighted(children, _own_planned(task, at)) if children else _own_planned(task, at)
    best_case = 100.0 * (built + unobserved) / total if total > 0 else None
    status = _status(planned, observed, best_case, behind, ahead)
    return TaskProgress(task, planned, observed, status, counts, built, total, product_ids=tuple(products))


def _all_products(schedule: WorkSchedule, tasks: Iterable[ScheduledTask]) -> list[str]:
    products: list[str] = []
    for task in tasks:
        products += list(task.products) + _all_products(schedule, [schedule.task(c) for c in task.children])
    return list(dict.fromkeys(products))


def _quantities(products: list[str], states: Mapping[str, str], quantities: Quantities) -> tuple[float, float, float]:
    """(built, total, not observed) quantity of ``products`` (a partly built one's by its share)."""
    built = float(sum(quantities.values.get(p, 0.0) * built_share(states.get(p)) for p in products))
    unobserved = quantities.total(p for p in products if states.get(p, NOT_OBSERVED) == NOT_OBSERVED)
    return built, quantities.total(products), unobserved


def _own_planned(task: ScheduledTask, at: datetime) -> float | None:
    """IfcTaskTime.Completion where set, else linear over ScheduleStart..ScheduleFinish."""
    if task.completion is not None:
        return 100.0 * task.completion
    start, finish = task.schedule_start, task.schedule_finish
    if start is None or finish is None:
        return None
    if at <= start:
        return 0.0
    if at >= finish or finish <= start:
        return 100.0
    return 100.0 * (at - start).total_seconds() / (finish - start).total_seconds()


def _weighted(children: list[TaskProgress], fallback: float | None) -> float | None:
    """The children's planned percentages weighted by their total quantities (equal weights when none has any)."""
    planned = [(child.planned_percent, child.total_quantity) for child in children if child.planned_percent is not None]
    if not planned:
        return fallback
    weights = [weight for _, weight in planned]
    if sum(weights) <= 0:
        weights = [1.0] * len(planned)
    return sum(p * w for (p, _), w in zip(planned, weights)) / sum(weights)


def _status(planned: float | None, observed: float | None, best_case: float | None, behind: float,
            ahead: float) -> TaskStatus:
    if observed is None:
        return TaskStatus.UNKNOWN
    if planned is not None and best_case is not None and best_case < planned - behind:
        return TaskStatus.BEHIND
    if planned is not None and observed > planned + ahead:
        return TaskStatus.AHEAD
    if observed >= FULL:
        return TaskStatus.COMPLETE
    if observed <= 0.0:
        return TaskStatus.NOT_STARTED
    return TaskStatus.IN_PROGRESS


def with_actuals(progress: ScheduleProgress, earlier: Iterable[ScheduleProgress]) -> ScheduleProgress:
    """``progress`` with each task's actual start (the first date it was seen with something built) and actual
    finish (the first date it was seen complete), from the same schedule's progress at earlier dates.

    Args:
        progress: The schedule's progress now.
        earlier: Its progress at earlier dates (any order; e.g. at each observation time of the twin's history).

    Returns:
        The progress with ``actual_start`` / ``actual_finish`` set where known.
    """
    history = sorted([*earlier, progress], key=lambda p: p.date)
    tasks = []
    for task in progress.tasks:
        rows = [p.task(task.task.global_id) for p in history]
        start = next((p.date for p, row in zip(history, rows) if (row.observed_percent or 0.0) > 0.0), None)
        finish = next((p.date for p, row in zip(history, rows) if (row.observed_percent or 0.0) >= FULL), None)
        tasks.append(replace(task, actual_start=start, actual_finish=finish))
    return replace(progress, tasks=tuple(tasks))


def _iso(value: datetime | None) -> str | None:
    return value.isoformat() if value is not None else None


def _rounded(value: float | None) -> float | None:
    return round(value, 1) if value is not None else None
