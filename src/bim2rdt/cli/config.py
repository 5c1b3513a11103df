"""`bim2rdt config`: the settings a command would run with, resolved from the environment, secrets masked."""

from __future__ import annotations

import json
import os

import typer

from bim2rdt.cli.common import print_json, print_table


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("config")(config_command)


def config_command(
    section: str | None = typer.Argument(None, help="Show only this section (e.g. registration, twin, hav)."),
    changed: bool = typer.Option(False, "--changed", help="Show only settings that a BIM2RDT_ variable sets."),
    as_json: bool = typer.Option(False, "--json", help="Print the resolved settings as one JSON document."),
) -> None:
    """Print the resolved settings (defaults overridden by BIM2RDT_* environment variables, nested with __):
    each setting's variable, its value and where it came from. Secrets show as ***."""
    from bim2rdt.config import get_settings, settings_record

    record = settings_record(get_settings())
    if section is not None:
        if section not in record:
            raise typer.BadParameter(f"no section {section!r}; sections: {', '.join(sorted(record))}")
        record = {section: record[section]}
    rows = [row for row in setting_rows(record, os.environ) if row[2] == "environment" or not changed]
    if as_json:
        print_json({variable: {"value": value, "from": origin} for variable, value, origin in rows})
        return
    print_table("bim2rdt settings", ["variable", "value", "from"], [(v, _shown(x), o) for v, x, o in rows])


def setting_rows(record: dict, environ: os._Environ | dict, prefix: str = "BIM2RDT_") -> list[tuple]:
    """Flatten a settings record into (variable, value, origin) rows: each section's fields become
    ``SECTION__FIELD`` variables (a field that is itself a mapping, such as the tolerance presets, stays one value,
    set as JSON); origin is "environment" when that variable or its section's variable is set."""
    rows = []
    present = {key.upper() for key in environ}
    for key, value in record.items():
        variable = f"{prefix}{key.upper()}"
        if isinstance(value, dict) and value and prefix == "BIM2RDT_":
            inner = setting_rows(value, environ, variable + "__")
            if variable in present:  # the whole section came as one JSON variable
                inner = [(name, item, "environment") for name, item, _ in inner]
            rows.extend(inner)
        else:
            rows.append((variable, value, "environment" if variable in present else "default"))
    return rows


def _shown(value: object) -> str:
    text = json.dumps(value) if isinstance(value, dict | list) else str(value)
    return text if len(text) <= 80 else text[:77] + "..."
