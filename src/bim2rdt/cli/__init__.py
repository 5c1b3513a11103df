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
    """Entry point: set the thread pools (:mod:`bim2rdt.cli.threads`), run the app, and turn library errors into
    one line and a non-zero exit. SIGINT and SIGTERM end any command with one line and 128 + the signal's number
    (130, 143); a failed or interrupted run leaves no empty output folder behind and marks partial output
    (:func:`bim2rdt.cli.common.close_run_folders`). Commands that stop cleanly on a signal (``hav listen``) set
    their own handlers for their loop."""
    from bim2rdt.cli.threads import limit_threads

    limit_threads()
    previous = _raise_on_stop_signals()
    try:
        code = _run()
    except Interrupted as stop:
        _ignore_stop_signals()
        code = 128 + stop.signum
        _say_interrupted()
    finally:
        _restore(previous)
    sys.exit(code)


class Interrupted(BaseException):
    """A stop signal (SIGINT, SIGTERM) reached the command: not an Exception, so no library handler swallows it."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _raise_on_stop_signals() -> dict:
    import signal

    def interrupt(signum, frame) -> None:
        raise Interrupted(signum)

    return {number: signal.signal(number, interrupt) for number in (signal.SIGINT, signal.SIGTERM)}


def _ignore_stop_signals() -> None:
    """A second Ctrl-C while the run's folder is tidied does not cut the tidying short."""
    import signal

    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, signal.SIG_IGN)


def _restore(previous: dict) -> None:
    import signal

    for number, handler in previous.items():
        signal.signal(number, handler)


def _say_interrupted() -> None:
    from bim2rdt.cli.common import close_run_folders

    partial = close_run_folders("was interrupted")
    where = f"; partial output in {', '.join(str(p) for p in partial)}" if partial else ""
    typer.secho(f"interrupted{where}", err=True, fg=typer.colors.YELLOW)


def _run() -> int:
    """The app's exit code; a failed run's folder is tidied (:func:`bim2rdt.cli.common.close_run_folders`)."""
    from bim2rdt.cli.common import close_run_folders

    try:
        code = _app_exit_code()
    except Interrupted:
        raise
    except BaseException:
        close_run_folders("failed")
        raise
    if code:
        close_run_folders("failed")
    return code


def _app_exit_code() -> int:
    try:
        returned = app(standalone_mode=False)
    except Bim2RdtError as error:
        typer.secho(f"error: {error}", err=True, fg=typer.colors.RED)
        return 1
    except typer.Exit as done:
        return done.exit_code
    except typer.Abort:
        typer.echo("aborted", err=True)
        return 130
    except OSError as error:  # the machine, not the code: say it in one line
        typer.secho(f"error: {_system_reason(error)}", err=True, fg=typer.colors.RED)
        return 1
    except Exception as error:  # click usage errors; typer >= 0.29 vendors click as typer._click
        import click

        if _database_failure(error):  # a database the machine cannot write (full disk): one line
            typer.secho(f"error: {_system_reason(error)}", err=True, fg=typer.colors.RED)
            return 1

        bad_value = isinstance(error, click.BadParameter | typer.BadParameter) and \
            type(error).__name__ != "MissingParameter"  # click's or typer's vendored click's
        if bad_value:  # a bad value: say which, in one line (a missing one still shows the usage)
            typer.secho(f"error: {error.format_message()}", err=True, fg=typer.colors.RED)
            return error.exit_code
        if isinstance(error, click.ClickException | typer.exceptions.TyperException) and hasattr(error, "show"):
            error.show()
            return error.exit_code
        raise
    if returned == 130:  # a KeyboardInterrupt that got past our handler: typer returns it as Exit(130)
        raise Interrupted(2)
    return returned if isinstance(returned, int) else 0  # typer returns an Exit's code in non-standalone mode


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
