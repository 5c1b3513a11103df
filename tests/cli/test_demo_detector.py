"""`demo --detector` is checked by perception's detector registry, in one line, before the day starts."""

from __future__ import annotations

import os
import subprocess
import sys


def _demo(*args: str, out) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", "demo", "--out", str(out), *args], capture_output=True,
                          text=True, timeout=120, env={**os.environ, "COLUMNS": "200"})


def test_an_unknown_detector_or_yoloe_without_its_files_is_refused_before_anything_runs(tmp_path):
    unknown = _demo("--detector", "oracle", out=tmp_path)
    assert unknown.returncode != 0 and "Traceback" not in unknown.stderr
    assert "unknown detector 'oracle'; choose one of geometric, yoloe, ideal" in " ".join(unknown.stderr.split())
    yoloe = _demo("--detector", "yoloe", out=tmp_path)
    assert yoloe.returncode != 0 and "--yoloe-weights" in yoloe.stderr
    assert not (tmp_path / "site.ifc").exists()
