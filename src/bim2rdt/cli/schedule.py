"""`bim2rdt progress MODEL --url TWIN`: how far each task of the model's work schedule has got, from the twin (and
the structure's judgements): planned %, observed %, status. A model without a schedule gets progress by storey
and by class. (The progress bar of long commands is :mod:`bim2rdt.cli.progress`.)"""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import typer

from bim2rdt.cli.common import print_json, print_table
from bim2rdt.cli.twin import URL_HELP, _open


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("progress")(progress_command)


def progress_command(
    ifc_file: Path = typer.Argument(..., help="The BIM with its work schedule (IFC4 or IFC4X3; IfcWorkSchedule)."),
    url: str | None = typer.Option(None, "--url", help=URL_HELP),
    at: str | None = typer.Option(None, "--at", help="Progress at this date: ISO 8601 (UTC if no offset); "
                                  "default: the twin's last observation."),
    structure: Path | None = typer.Option(None, "--structure", help="The structure's judgements (structure.json of "
                                          "verify or demo); default: structure.json beside a SQLite twin, if any."),
    as_json: bool = typer.Option(False, "--json", help="Print progress.json's document instead of a table."),
) -> None:
    """Each task's planned %, observed % (built quantity over total) and status: not started, in progress,
    complete, behind, ahead or unknown (its products not observed)."""
    from bim2rdt.config import get_settings
    from bim2rdt.twin import progress_of, read_structure_statuses

    config = get_settings().progress
    when = _date(at) if at is not None else None
    judged = read_structure_statuses(structure or _beside(url))
    with _open(ifc_file, url) as twin:
        progress, _, groups = progress_of(twin, at=when, structure=judged, behind_percent=config.behind_percent,
                                       ahead_percent=config.ahead_percent)
    if progress is None:
        _print_groups(ifc_file, groups, as_json)
        return
    record = progress.to_dict()
    if as_json:
        print_json(record)
        return
    print_table(f"{record['schedule']['name']} at {record['date'][:19]}",
                ("task", "start", "finish", "planned %", "observed %", "status", "built / not built / not seen"),
                [_row(task, record["tasks"]) for task in record["tasks"]])


def _row(task: dict, tasks: list[dict]) -> tuple:
    parents = {child: t["global_id"] for t in tasks for child in t["children"]}
    depth, node = 0, task["global_id"]
    while node in parents:
        node, depth = parents[node], depth + 1
    counts = task["products"]
    return (f"{'  ' * depth}{task['identification'] or ''} {task['name'] or ''}".rstrip(),
            (task["planned_start"] or "-")[:10], (task["planned_finish"] or "-")[:10], _num(task["planned_percent"]),
            _num(task["observed_percent"]), task["status"],
            f"{counts['as planned'] + counts['deviating']} / {counts['not built']} / {counts['not observed']}")


def _print_groups(ifc_file: Path, groups, as_json: bool) -> None:
    if as_json:
        print_json({"schedule": None, "groups": [g.to_dict() for g in groups]})
        return
    print_table(f"{ifc_file.name} has no work schedule: progress by storey and by class",
                ("by", "group", "observed %", "built / not built / not seen"),
                [(g.by, g.name, _num(g.observed_percent),
                  f"{g.products['as planned'] + g.products['deviating']} / {g.products['not built']} / "
                  f"{g.products['not observed']}") for g in groups])


def _beside(url: str | None) -> Path:
    """structure.json beside a SQLite twin given as a path or sqlite:/// URL (a path that never exists else)."""
    if url and url.startswith("sqlite:///"):
        return Path(url.removeprefix("sqlite:///")).parent / "structure.json"
    if url and "://" not in url:
        return Path(url).parent / "structure.json"
    return Path("/nonexistent/structure.json")


def _date(text: str) -> datetime:
    try:
        when = datetime.fromisoformat(text)
    except ValueError:
        raise typer.BadParameter(f"--at {text!r} is not an ISO 8601 date") from None
    return when if when.tzinfo else when.replace(tzinfo=timezone.utc)


def _num(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"
