"""verify's --out holds one run's set: an interrupted run (SIGINT, a subprocess) leaves the earlier run's files
whole and says what it kept; a run on an IFC2X3 model leaves no twin.ifc of an earlier run; the terminal summary
names each frame's fix and each issue; BCF files get the mode every output gets."""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

import bim2rdt
from bim2rdt.cli import app
from bim2rdt.sim.site import build_site_ifc
from tests.sources.bags import write_bag
from tests.verify.ifc2x3_room import write_room_ifc2x3

runner = CliRunner()
OUTPUTS = ("twin.db", "twin.json", "twin.ifc", "issues.bcf", "localization.json", "report.html", "config.json",
           "structure.json")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """The site (IFC4), the IFC2X3 room and a bag of 4 small frames (random depth: each is refused at once)."""
    folder = tmp_path_factory.mktemp("outputs")
    write_bag(folder / "small.mcap", [1.0 + k for k in range(4)])
    return build_site_ifc(folder / "site.ifc"), write_room_ifc2x3(folder / "room.ifc"), folder / "small"


def _verify(ifc, bag, out):
    result = runner.invoke(app, ["verify", str(ifc), str(bag), "--out", str(out), "--detector", "none"])
    assert result.exit_code == 3, result.output  # no frame of the random-depth bag localizes: its set is written
    return result.output


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.is_file()}


def test_a_run_on_an_ifc2x3_model_leaves_no_twin_ifc_of_an_earlier_run(inputs, tmp_path):
    site, room, bag = inputs
    out = tmp_path / "verify"
    _verify(site, bag, out)
    assert (out / "twin.ifc").is_file()
    said = " ".join(_verify(room, bag, out).split())
    assert not (out / "twin.ifc").exists()
    assert sorted(_files(out)) == sorted(set(OUTPUTS) - {"twin.ifc"})
    assert "no twin.ifc" in said and "IFC2X3" in said
    assert b"room.ifc" in (out / "twin.json").read_bytes()  # the new run's twin, not the site's


def test_every_output_gets_the_same_mode_the_bcf_included(inputs, tmp_path):
    site, _, bag = inputs
    out = tmp_path / "verify"
    _verify(site, bag, out)
    umask = os.umask(0)
    os.umask(umask)
    modes = {name: stat.S_IMODE((out / name).stat().st_mode) for name in OUTPUTS if name != "twin.db"}
    assert set(modes.values()) == {0o666 & ~umask}, modes


def test_a_user_file_in_out_stays_and_no_staging_folder_is_left(inputs, tmp_path):
    site, _, bag = inputs
    out = tmp_path / "verify"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / ".verify-run-999999999-abcdef").mkdir()  # a killed run's: its process is gone
    _verify(site, bag, out)
    assert (out / "notes.txt").read_text() == "mine"
    assert not list(out.glob(".verify-run-*"))


def test_an_interrupted_run_leaves_the_earlier_runs_set_whole_and_says_what_it_kept(inputs, tmp_path):
    site, _, bag = inputs
    out = tmp_path / "verify"
    _verify(site, bag, out)
    before = _files(out)
    first_db = (out / "twin.db").stat()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(bim2rdt.__file__).resolve().parents[1]),
                                                        os.environ.get("PYTHONPATH", "")])}
    process = subprocess.Popen([sys.executable, "-m", "bim2rdt", "verify", str(site), str(bag), "--out", str(out),
                                "--detector", "none"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env=env)
    _wait_for_a_new_twin_db(out, first_db, process)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr  # 0: the run ended before the signal reached it
    assert not list(out.glob(".verify-run-*"))
    after = _files(out)
    if "this run's outputs are complete" in stderr:  # the signal came while the set was moved in: it all is
        assert sorted(after) == sorted(before) and all(after[n] != before[n] for n in ("localization.json",))
    else:
        assert after == before, [n for n in after if after.get(n) != before.get(n)]
        assert f"kept {out} as the earlier run left it" in stderr, stderr
    assert "Traceback" not in stderr


def _wait_for_a_new_twin_db(out: Path, first, process, seconds: float = 120.0) -> None:
    """Until this run's twin.db exists (anywhere under ``out``): the run is writing its outputs."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for path in out.rglob("twin.db"):
            try:
                info = path.stat()
            except FileNotFoundError:
                continue
            if path.parent != out or (info.st_ino, info.st_mtime_ns) != (first.st_ino, first.st_mtime_ns):
                return
        assert process.poll() is None, process.communicate()
        time.sleep(0.005)
    raise AssertionError("the run never wrote its twin.db")


def test_the_summary_gives_each_fix_each_issue_and_where_publish_wrote(sensors, tmp_path):
    truth = json.loads((sensors / "pcl" / "office1_truth.json").read_text())
    g = ",".join(str(v) for v in truth["depth_correction"]["g"])
    out, bag = tmp_path / "verify", tmp_path / "results.mcap"
    result = runner.invoke(app, ["verify", str(sensors / "pcl" / "office1.ifc"), str(sensors / "pcl" / "office1.pcd"),
                                 "--prior", "1.30,-4.55,1.38,82", "--depth-correction", g, "--out", str(out),
                                 "--publish", str(bag)])
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    frame = json.loads((out / "localization.json").read_text())["frames"][0]
    x, y, z = (row[3] for row in frame["pose"][:3])
    assert f"{x:.2f}, {y:.2f}, {z:.2f}" in text and "free directions" in text
    twin = json.loads((out / "twin.json").read_text())["elements"]
    issues = [e for e in twin if e["status"] in ("deviating", "missing", "new")]
    assert issues and all(f"{e['status']}: " in text and e["global_id"] in text for e in issues)
    assert text.count(" new: ") + text.count(" deviating: ") + text.count(" missing: ") == len(issues)
    assert f"published the results bag: {tmp_path / 'results'}/" in text and (out / "maps").is_dir()
