"""`bim2rdt info FILE` (what is in an IFC file, and is it ready to be the robot's map) and `bim2rdt bench ifc`."""

from __future__ import annotations

from pathlib import Path

import typer

from rich.console import Console

from bim2rdt.cli.common import console, out_path, print_json, print_table

_status = Console(stderr=True)  # progress bars go to stderr so stdout (tables or --json) stays clean

FAMILY_ROWS = 25
WARNING_ROWS = 20
BENCH_FILE = "Office_A_20110811.ifc"


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("info")(info_command)
    app.command("site")(site_command)
    bench_app.command("ifc")(bench_ifc_command)


def info_command(
    ifc_file: Path = typer.Argument(..., help="IFC file (IFC2X3, IFC4 or IFC4X3)."),
    readiness: bool = typer.Option(False, "--readiness", help="Add the paper's model-conditioning check: "
                                   "families, storeys, elevations, unknown families, off-limits zones, geo-reference."),
    geometry: bool = typer.Option(True, "--geometry/--no-geometry", help="Tessellate (cached by file hash) to find "
                                  "elements whose geometry fails and locate identity-placed elements."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document instead of tables."),
    strict: bool = typer.Option(False, "--strict", help="Also check every attribute value's type against the "
                                "schema, and exit 1 after the report if the reader had to read past anything "
                                "(dangling references, malformed entities, geometry that fails)."),
) -> None:
    """Print schema, length unit, storeys with elevations (m), element counts by class and the families found,
    and what the reader had to read past (warnings, with the elements they affect)."""
    model = _load(ifc_file, geometry, strict)
    checks = _readiness(model) if readiness else None
    if as_json:
        print_json(_info_payload(model, checks))
    else:
        _print_info(model)
        if checks is not None:
            print_table("BIM readiness (model conditioning)", ["check", "status", "result", "examples"],
                        [(c.name, c.status, c.summary, "; ".join(c.examples[:3])) for c in checks])
    if strict:
        _fail_if_doubtful(model)


def site_command(
    out: Path = typer.Argument(Path("site.ifc"), parser=out_path, metavar="OUT", help="Where to write the IFC4 file "
                               "(written atomically; an existing file keeps its permissions)."),
    force: bool = typer.Option(False, "--force", help="Replace a symlink, device node, FIFO or socket at OUT with a "
                               "regular file (refused without it)."),
) -> None:
    """Write the embedded construction site (the default site of the demo) as an IFC4 file."""
    from bim2rdt.atomic import NotRegularFileError, WriteError, check_writable_file
    from bim2rdt.sim.site import build_site_ifc

    try:
        check_writable_file(out, replace_special=force)
    except NotRegularFileError as error:
        raise WriteError(f"{error} (--force replaces it)") from None
    path = build_site_ifc(out, replace_special=force)
    console.print(f"wrote {path} ({path.stat().st_size} bytes)")


def bench_ifc_command(
    ifc_file: Path | None = typer.Option(None, "--file", help=f"IFC file to time (default: {BENCH_FILE} of the "
                                         "shared samples, BIM2RDT_SAMPLES)."),
    repeat: int = typer.Option(3, "--repeat", min=1, help="Interleaved runs of each contender; the best is kept."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table."),
) -> None:
    """Time load_ifc (parse + semantics + tessellation + cache write) against a bare ifcopenshell geometry
    iterator loop in the same run (target: <= 15 % overhead), and the cached reload (target: < 0.5 s)."""
    from rich.progress import Progress

    from bim2rdt.bench.ifc import run_ifc_bench

    path = ifc_file or _default_bench_file()
    with Progress(console=_status, transient=True, disable=not _status.is_terminal) as progress:
        task = progress.add_task(f"benchmarking {path.name}", total=2 * repeat + max(3, repeat))
        result = run_ifc_bench(path, repeat, step=lambda label: progress.update(task, advance=1, description=label))
    if as_json:
        from bim2rdt.config import get_settings, settings_record

        print_json({**result.to_dict(), "settings": settings_record(get_settings())})
        return
    summary = result.to_dict()
    bare = result.bare_loop
    rows = [("bare ifcopenshell iterator loop", bare.wall_s, bare.cpu_s, "1.000", "peer", ""),
            ("bim2rdt load_ifc, cold", result.load.wall_s, result.load.cpu_s, f"{result.load.cpu_s / bare.cpu_s:.3f}",
             f"<= {1 + summary['overhead_target']:.2f}", "yes" if summary["overhead_ok"] else "NO"),
            ("bim2rdt load_ifc, cached", result.cached.wall_s, result.cached.cpu_s,
             f"{result.cached.cpu_s / bare.cpu_s:.3f}", f"< {summary['cached_target_s']} s wall",
             "yes" if summary["cached_ok"] else "NO")]
    print_table(f"IFC load benchmark: {result.file} ({result.shapes} shapes, best of {repeat})",
                ["contender", "wall s", "CPU s", "CPU vs bare loop", "target", "met"], rows)


def _load(path: Path, geometry: bool, validate: bool = False):
    from rich.progress import Progress

    from bim2rdt.bim import load_ifc
    from bim2rdt.config import get_settings, ifc_cache_dir

    cache_dir = ifc_cache_dir(get_settings()) if geometry else None
    with Progress(console=_status, transient=True, disable=not _status.is_terminal) as progress:
        task = progress.add_task(f"reading {path.name}", total=100)
        return load_ifc(path, geometry=geometry, validate=validate, cache_dir=cache_dir,
                        progress=lambda done, total: progress.update(task, completed=done, total=total))


def _fail_if_doubtful(model) -> None:
    """--strict: any reader warning or geometry failure is an error (after the report was printed)."""
    from bim2rdt.bim import BimError

    doubts = [w.message for w in model.warnings]
    doubts += [f"{f.ifc_class} {f.global_id}: geometry fails ({f.reason})" for f in model.geometry_failures]
    if doubts:
        more = f" (and {len(doubts) - 1} more)" if len(doubts) > 1 else ""
        raise BimError(f"{model.path.name}: --strict: {doubts[0]}{more}")


def _readiness(model):
    """The checks, with the knowledge-base prior table when bim2rdt.semantics provides it."""
    from bim2rdt.bim.readiness import check_readiness

    try:
        from bim2rdt.semantics import KnowledgeBasePriors
    except ImportError:
        return check_readiness(model, None)
    return check_readiness(model, KnowledgeBasePriors())


def _print_info(model) -> None:
    frame = model.site_frame
    console.print(f"[bold]{model.path.name}[/bold]  schema {model.schema}  unit {model.unit_name} "
                  f"(x{model.unit_scale:g} -> m)  {len(model.elements)} elements  geo-reference: {frame.source}")
    print_table("Storeys", ["storey", "elevation (m)"],
                [(s.name, "unset" if s.elevation is None else round(s.elevation, 3)) for s in model.storeys])
    print_table("Elements by class", ["IFC class", "count"], list(model.counts_by_class().items()))
    families = list(model.families().items())
    more = len(families) - FAMILY_ROWS
    print_table(f"Families ({len(families)})", ["family", "elements"],
                families[:FAMILY_ROWS] + ([(f"... and {more} more (--json lists all)", "")] if more > 0 else []))
    if model.geometry_failures:
        console.print(f"[yellow]{len(model.geometry_failures)} elements whose geometry failed (skipped)[/yellow]")
    if model.warnings:
        print_table(f"Reader warnings ({len(model.warnings)}): read past, the elements affected may be wrong",
                    ["kind", "warning"], [(w.kind, w.message) for w in model.warnings[:WARNING_ROWS]]
                    + ([(f"... and {len(model.warnings) - WARNING_ROWS} more (--json lists all)", "")]
                       if len(model.warnings) > WARNING_ROWS else []))


def _info_payload(model, checks) -> dict:
    frame = model.site_frame
    payload = {
        "file": str(model.path), "sha256": model.digest, "schema": model.schema, "unit": model.unit_name,
        "unit_scale": model.unit_scale, "elements": len(model.elements),
        "storeys": [{"name": s.name, "global_id": s.global_id, "elevation_m": s.elevation} for s in model.storeys],
        "counts_by_class": model.counts_by_class(), "families": model.families(),
        "zones": [{"name": z.name, "global_id": z.global_id, "off_limits": z.off_limits, "kind": z.kind}
                  for z in model.zones],
        "site_frame": {"source": frame.source, "crs": frame.crs_name, "latitude_deg": frame.latitude_deg,
                       "longitude_deg": frame.longitude_deg, "elevation_m": frame.elevation_m,
                       "true_north_deg": frame.true_north_deg, "T_map_world": frame.T_map_world},
        "geometry_failures": [f.__dict__ for f in model.geometry_failures],
        "warnings": [w.__dict__ for w in model.warnings],
    }
    if checks is not None:
        payload["readiness"] = [c.__dict__ for c in checks]
    return payload


def _default_bench_file() -> Path:
    from bim2rdt.bim import BimError
    from bim2rdt.config import default_samples_dir, get_settings

    folder = get_settings().samples or default_samples_dir()
    path = Path(folder) / BENCH_FILE
    if not path.is_file():
        raise BimError(f"{path}: benchmark file absent (set BIM2RDT_SAMPLES or pass --file)")
    return path
