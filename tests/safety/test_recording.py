"""`hav analyze` answers right or says why not (issue 10, section 4): time order, units, the trigger, a BOM."""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys

import numpy as np
import pytest

from bim2rdt.safety import HavError, daily_exposure
from bim2rdt.safety.analysis import analyze_recording
from bim2rdt.safety.recording import GRAVITY, Recording, read_accel_csv, write_accel_csv
from bim2rdt.sim.vibration import session_signal

from hav_helpers import T0

FS = 2000.0


@pytest.fixture(scope="module")
def grinding():
    return session_signal([("idle", 3), ("grinder", 30), ("idle", 3)], FS, a_hv={"grinder": 6.0})


def run_cli(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=180, **kw)


def test_shuffled_rows_are_refused_with_the_row(tmp_path, grinding):
    path = write_accel_csv(tmp_path / "day.csv", grinding, FS)
    lines = path.read_text().splitlines()
    rows = lines[1:]
    rows[500], rows[501] = rows[501], rows[500]
    path.write_text("\n".join([lines[0], *rows]) + "\n")
    with pytest.raises(HavError, match=r"time does not increase at data row 502 .* sort the recording by time"):
        read_accel_csv(path)
    result = run_cli("hav", "analyze", str(path), "--out", str(tmp_path))
    assert result.returncode == 1 and "data row 502" in result.stderr and len(result.stderr.splitlines()) == 1


def test_data_in_g_is_converted_with_a_note(tmp_path, grinding):
    metres = analyze_recording(read_accel_csv(write_accel_csv(tmp_path / "ms2.csv", grinding, FS)))
    recording = read_accel_csv(write_accel_csv(tmp_path / "g.csv", grinding / GRAVITY, FS))
    assert recording.units == "g" and "read as g" in recording.notes[0]
    in_g = analyze_recording(recording)
    assert in_g.a8 == pytest.approx(metres.a8, rel=1e-3) and in_g.a8 == pytest.approx(daily_exposure(6.0, 30.0),
                                                                                      rel=0.05)
    assert read_accel_csv(tmp_path / "g.csv", units="m/s2").units == "m/s2"  # the user may say otherwise


def test_explicit_units_that_gravity_contradicts_run_with_a_warning(tmp_path, grinding):
    in_g = write_accel_csv(tmp_path / "g.csv", grinding / GRAVITY, FS)
    metres = write_accel_csv(tmp_path / "ms2.csv", grinding, FS)
    for path, units, looks in ((in_g, "m/s2", "g"), (metres, "g", "m/s2")):
        notes = read_accel_csv(path, units=units).notes
        assert len(notes) == 1 and f"--units {units} given" in notes[0] and f"gravity in {looks}" in notes[0]
    assert read_accel_csv(in_g, units="g").notes == read_accel_csv(metres, units="m/s2").notes == []


@pytest.mark.parametrize("factor", [1e19, 1000.0, 0.3])
def test_values_in_no_known_unit_are_refused(tmp_path, grinding, factor):
    path = write_accel_csv(tmp_path / "odd.csv", grinding * factor, FS)
    with pytest.raises(HavError, match="neither ~9.81 .* --units"):
        read_accel_csv(path)


def test_data_without_gravity_is_read_with_a_note_that_units_are_unchecked(tmp_path, grinding):
    recording = read_accel_csv(write_accel_csv(tmp_path / "hp.csv", grinding - grinding.mean(axis=0), FS))
    assert recording.units == "m/s2" and "could not be checked" in recording.notes[0]


def test_a_steady_vibration_under_the_trigger_is_reported_with_its_a8():
    fs, seconds = 1000.0, 600.0  # 5 m/s^2 r.m.s. at 125 Hz: weighted 0.64 m/s^2, under the 1 m/s^2 trigger
    t = np.arange(int(fs * seconds)) / fs
    xyz = np.zeros((t.size, 3))
    xyz[:, 0] = 5.0 * np.sqrt(2) * np.sin(2 * np.pi * 125.0 * t)
    xyz[:, 2] = GRAVITY
    report = analyze_recording(Recording(T0, fs, xyz))
    assert report.a8 == 0.0 and report.activities == []
    expected = daily_exposure(5.0 * 0.1273, seconds)  # |Wh(125 Hz)| = 0.127: the 0.226 over an hour
    assert report.untriggered_a8 == pytest.approx(expected, rel=0.03)
    assert report.untriggered_s == pytest.approx(seconds, abs=1.0)
    assert any("under the 1 m/s² activity trigger" in note for note in report.notes)


def test_a_csv_with_a_byte_order_mark_is_read(tmp_path, grinding):
    path = write_accel_csv(tmp_path / "bom.csv", grinding, FS)
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    result = run_cli("hav", "analyze", str(path), "--out", str(tmp_path), "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["a8"] == pytest.approx(daily_exposure(6.0, 30.0), rel=0.05)


def _file_size_limit(limit: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG, as on a full disk
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def test_a_full_disk_while_writing_the_plot_leaves_no_png(tmp_path, grinding):
    path = write_accel_csv(tmp_path / "day.csv", grinding, FS)
    out = tmp_path / "plots"
    out.mkdir()
    result = run_cli("hav", "analyze", str(path), "--out", str(out), preexec_fn=_file_size_limit(8192),
                     env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
    assert result.returncode == 1 and "cannot write the plot" in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert list(out.iterdir()) == []  # neither a truncated PNG nor a temporary file
