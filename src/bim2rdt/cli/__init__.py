"""The bim2rdt command line: a thin typer app that imports heavy modules lazily.

Each module in this package owns the commands of one domain and exposes ``register(app, bench_app)``; they are
discovered here, so adding a command never means editing this file. Library errors (``Bim2RdtError``) become
a one-line message on stderr and exit code 1; so do errors of the machine (an ``OSError`` such as a full disk,
a SQLite "database or disk is full") that reach the edge; usage errors exit 2 (typer's convention).
"""

from __future__ import annotations

import importlib
import pkgutil
import sys

import typer

from bim2rdt import __version__
from bim2rdt.errors import Bim2RdtError

app = typer.Typer(
    name="bim2rdt",
    help="BIM to robot-ready site digital twin: registration, IFC twin write-back, hand-arm vibration safety.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
bench_app = typer.Typer(help="Benchmarks: a table (or --json) with ratios against a peer measured in the same run.",
                        no_args_is_help=True)
app.add_typer(bench_app, name="bench")


def _version_callback(value: bool) -> None:
    if value:
        typer.echo(f"bim2rdt {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version_callback, is_eager=True,
                                 help="Print the version and exit."),
) -> None:
    """bim2rdt: turn a static IFC model into a live, robot-ready digital twin of the site, safety first."""


def _register_commands() -> None:
    for module_info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{__name__}.{module_info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(app, bench_app)


_register_commands()


def main() -> None:
    """Entry point: run the app, turning library errors into one line and a non-zero exit."""
    try:
        app(standalone_mode=False)
    except Bim2RdtError as error:
        typer.secho(f"error: {error}", err=True, fg=typer.colors.RED)
        sys.exit(1)
    except typer.Exit as done:
        sys.exit(done.exit_code)
    except typer.Abort:
        typer.echo("aborted", err=True)
        sys.exit(130)
    except OSError as error:  # the machine, not the code: say it in one line
        typer.secho(f"error: {_system_reason(error)}", err=True, fg=typer.colors.RED)
        sys.exit(1)
    except Exception as error:  # click usage errors; typer >= 0.29 vendors click as typer._click
        import click

        if _database_failure(error):  # a database the machine cannot write (full disk): one line
            typer.secho(f"error: {_system_reason(error)}", err=True, fg=typer.colors.RED)
            sys.exit(1)

        bad_value = isinstance(error, click.BadParameter | typer.BadParameter) and \
            type(error).__name__ != "MissingParameter"  # click's or typer's vendored click's
        if bad_value:  # a bad value: say which, in one line (a missing one still shows the usage)
            typer.secho(f"error: {error.format_message()}", err=True, fg=typer.colors.RED)
            sys.exit(error.exit_code)
        if isinstance(error, click.ClickException | typer.exceptions.TyperException) and hasattr(error, "show"):
            error.show()
            sys.exit(error.exit_code)
        raise


def _database_failure(error: Exception) -> bool:
    """An SQLite or SQLAlchemy OperationalError (the database cannot be written: disk full, I/O error)."""
    return type(error).__name__ == "OperationalError" and type(error).__module__.split(".")[0] in (
        "sqlite3", "sqlalchemy")


def _system_reason(error: Exception) -> str:
    if not isinstance(error, OSError):
        original = getattr(error, "orig", None) or error
        return f"SQLite: {' '.join(str(original).splitlines()[:1])}"
    where = f"{error.filename}: " if error.filename else ""
    return f"{where}{error.strerror or error}"
