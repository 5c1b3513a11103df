"""`bim2rdt twin state|history|export`: read a site's twin (its BIM plus its history store) and export it."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import typer

from bim2rdt.cli.common import console, out_path, print_json, print_table, run_folder

twin_app = typer.Typer(help="The site's digital twin: its state (now or at a past time), an element's history, "
                       "and exports to IFC, BCF and JSON.", no_args_is_help=True)

URL_HELP = ("Twin history: a SQLite file (out/demo/twin.db), or a URL: sqlite:///path/twin.db or "
            "postgresql+psycopg://user:password@host/db (default: BIM2RDT_TWIN__URL, else BIM2RDT_DATA_DIR/twin.db).")


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.add_typer(twin_app, name="twin")


@twin_app.command("state")
def state_command(
    ifc_file: Path = typer.Argument(..., help="The BIM the twin is kept over (IFC2X3, IFC4 or IFC4X3)."),
    url: str | None = typer.Option(None, "--url", help=URL_HELP),
    at: str | None = typer.Option(None, "--at", help="Show the twin as it was at this time: ISO 8601 "
                                  "(2026-05-04T10:30:00+00:00; UTC if no offset) or Unix seconds."),
    everything: bool = typer.Option(False, "--all", help="Include the BIM elements never observed."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document instead of a table."),
    partial: bool = typer.Option(False, "--partial", help="Show a twin a run did not finish (refused otherwise: "
                                 "its state is partial), with a warning."),
) -> None:
    """Each observed element's status, deviation against its tolerance preset, fit and evidence."""
    with _open(ifc_file, url, partial) as twin:
        states = twin.state(None if at is None else _time(at))
        unfinished = twin.unfinished_runs()
    if unfinished:
        typer.secho(f"warning: PARTIAL twin: the {unfinished[-1][0]} run that built it did not finish; these states "
                    "are incomplete", err=True, fg=typer.colors.YELLOW)
    shown = [s for s in states.values() if everything or s.status.value != "not observed"]
    if as_json:
        print_json([s.to_dict() for s in shown])
        return
    print_table(f"Twin of {ifc_file.name}" + (f" at {at}" if at else ""),
                ("element", "GlobalId", "status", "shift m", "tilt °", "yaw °", "tolerance", "fitness", "robot",
                 "seen (UTC)"), [_state_row(s) for s in shown])


@twin_app.command("history")
def history_command(
    ifc_file: Path = typer.Argument(..., help="The BIM the twin is kept over."),
    global_id: str = typer.Argument(..., help="The element's GlobalId (or a new object's, from `twin state`)."),
    url: str | None = typer.Option(None, "--url", help=URL_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document instead of a table."),
) -> None:
    """Every recorded change of one element, oldest first: observations, status changes, safety events."""
    with _open(ifc_file, url) as twin:
        events = twin.history(global_id)
    if as_json:
        print_json([vars(e) for e in events])
        return
    print_table(f"History of {global_id}", ("seq", "time (UTC)", "kind", "source", "what"),
                [(e.seq, _utc(e.time), e.kind, e.source, _what(e)) for e in events])


@twin_app.command("export")
def export_command(
    ifc_file: Path = typer.Argument(..., help="The BIM the twin is kept over."),
    url: str | None = typer.Option(None, "--url", help=URL_HELP),
    out: Path = typer.Option(Path("out/twin"), "--out", parser=out_path, callback=run_folder,
                             help="Folder for twin.ifc, issues.bcf and twin.json."),
) -> None:
    """Write the twin as IFC (IFC4/IFC4X3 models), BCF issues (one topic per deviating, missing or new element)
    and JSON."""
    from bim2rdt.twin import TwinError

    with _open(ifc_file, url) as twin:
        console.print(f"wrote {twin.export_bcf(out / 'issues.bcf')}")
        console.print(f"wrote {twin.export_json(out / 'twin.json')}")
        try:
            console.print(f"wrote {twin.export_ifc(out / 'twin.ifc')}")
        except TwinError as error:
            console.print(f"no IFC written: {error}")


def _open(ifc_file: Path, url: str | None, partial: bool = False):
    from bim2rdt.bim import load_ifc
    from bim2rdt.config import get_settings, ifc_cache_dir
    from bim2rdt.twin import DigitalTwin

    settings = get_settings()
    model = load_ifc(ifc_file, cache_dir=ifc_cache_dir(settings))
    return DigitalTwin.open(twin_url(url) if url else settings.twin.resolved_url(settings.data_dir), model,
                            tolerances=settings.twin.tolerance_policy(), min_fitness=settings.twin.min_fitness,
                            create=False, partial=partial)


def twin_url(given: str) -> str:
    """``--url`` as the store takes it: a URL as given, a plain path (no ``scheme://``) as a SQLite file."""
    return given if "://" in given else f"sqlite:///{Path(given).resolve()}"


def follow_up_command(ifc_file: Path, history: Path) -> str:
    """The command that shows the twin a run wrote, ready to paste."""
    import shlex

    return f"bim2rdt twin state {shlex.quote(str(ifc_file))} --url {shlex.quote(str(history))}"


def _time(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        pass
    try:
        when = datetime.fromisoformat(text)
    except ValueError:
        raise typer.BadParameter(f"--at {text!r} is neither ISO 8601 nor Unix seconds") from None
    return (when if when.tzinfo else when.replace(tzinfo=timezone.utc)).timestamp()


def _state_row(s) -> tuple:
    d, t, f = s.deviation, s.tolerance, s.fit
    return (s.family or "-", s.global_id, s.status.value, _num(d and d.translation, 3), _num(d and d.tilt_deg, 1),
            _num(d and d.yaw_deg, 1), f"{t.name} {100 * t.translation:g}cm/{t.rotation_deg:g}°" if t else "-",
            _num(f and f.fitness, 2), s.robot or "-", _utc(s.evidence.time)[11:19] if s.evidence else "-")


def _what(event) -> str:
    data = event.data
    if event.kind == "status":
        return f"{data['from']} -> {data['to']}"
    if event.kind == "safety":
        return f"{data['kind']} ({data['subject']})"
    return str(data.get("status", ""))


def _utc(time: float) -> str:
    return datetime.fromtimestamp(time, timezone.utc).isoformat(timespec="seconds")


def _num(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"
