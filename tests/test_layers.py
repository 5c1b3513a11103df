"""The import layers (.importlinter, docs/concepts/architecture.md): library packages never import sim, demo or
bench, and no layer imports one above it. Checked with import-linter on the real import graph, not with a grep."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import bim2rdt

CHECKOUT = Path(__file__).resolve().parents[1]
CONTRACT = CHECKOUT / ".importlinter"


def _lint(contract: Path, package_parent: Path) -> subprocess.CompletedProcess:
    """Run lint-imports on the ``bim2rdt`` package found in ``package_parent``."""
    code = "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"
    return subprocess.run([sys.executable, "-c", code, str(contract), "--no-cache", "--no-logo"],
                          capture_output=True, text=True, timeout=300, cwd=package_parent,
                          env={"PYTHONPATH": str(package_parent), "PATH": str(Path(sys.executable).parent)})


def test_the_package_keeps_its_import_layers():
    result = _lint(CONTRACT, Path(bim2rdt.__file__).parents[1])
    assert result.returncode == 0, result.stdout + result.stderr
    assert "1 kept, 0 broken" in result.stdout


def test_the_contract_catches_the_mission_importing_the_simulators_truth(tmp_path):
    """The violation this contract was written against (issue 9): planted in a copy of the package."""
    shutil.copytree(Path(bim2rdt.__file__).parent, tmp_path / "bim2rdt",
                    ignore=shutil.ignore_patterns("__pycache__"))
    run = tmp_path / "bim2rdt" / "mission" / "run.py"
    run.write_text(run.read_text() + "\nfrom bim2rdt.sim.truth import pose_error  # noqa: E402,F401\n")
    result = _lint(CONTRACT, tmp_path)
    assert result.returncode != 0
    assert "bim2rdt.mission.run -> bim2rdt.sim.truth" in result.stdout


def test_the_contract_keeps_the_demo_and_the_benchmarks_apart(tmp_path):
    """``demo | bench``: the demo runs the paper's scenarios from ``evaluation``, never from ``bench``."""
    shutil.copytree(Path(bim2rdt.__file__).parent, tmp_path / "bim2rdt",
                    ignore=shutil.ignore_patterns("__pycache__"))
    run = tmp_path / "bim2rdt" / "demo" / "run.py"
    run.write_text(run.read_text() + "\nfrom bim2rdt.bench.planning import run_planning_bench  # noqa: E402,F401\n")
    result = _lint(CONTRACT, tmp_path)
    assert result.returncode != 0
    assert "bim2rdt.demo.run -> bim2rdt.bench.planning" in result.stdout
