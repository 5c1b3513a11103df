"""`make` says what it is doing before each quiet step of its set-up (a first install takes minutes: a silent
terminal looks hung)."""

from __future__ import annotations

from pathlib import Path

MAKEFILE = Path(__file__).resolve().parents[1] / "Makefile"


def test_every_quiet_install_step_is_announced_by_the_line_before_it():
    lines = [line.strip() for line in MAKEFILE.read_text().splitlines()]
    installs = [i for i, line in enumerate(lines) if "pip install" in line or "-m venv" in line]
    assert len(installs) >= 3
    for i in installs:
        assert lines[i - 1].startswith("@echo \"make: "), lines[i]
    assert any("installing bim2rdt" in line for line in lines)
