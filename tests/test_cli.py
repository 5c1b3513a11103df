"""The CLI shell: --help, --version, and bad commands exit non-zero."""

from __future__ import annotations

import subprocess
import sys

from bim2rdt import __version__


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=120)


def test_version_prints_the_package_version():
    result = run_cli("--version")
    assert result.returncode == 0
    assert result.stdout.strip() == f"bim2rdt {__version__}"


def test_help_lists_the_bench_group():
    result = run_cli("--help")
    assert result.returncode == 0
    assert "bench" in result.stdout


def test_unknown_command_exits_non_zero_with_a_message():
    result = run_cli("no-such-command")
    assert result.returncode != 0
    assert "no-such-command" in (result.stderr + result.stdout)


def test_the_benchmarks_progress_bar_runs_no_thread_beside_the_timed_code():
    """A refresh thread waking on the same core took the GIL from the code `bench hav` times."""
    import threading

    from bim2rdt.cli.hav_output import progress

    before = threading.active_count()
    with progress(3, "timed rounds") as tick:
        assert threading.active_count() == before
        tick(1)
        assert threading.active_count() == before
