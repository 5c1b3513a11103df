"""Recorded files: reading a CSV, and what a recording's artefacts do to the day's report."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bim2rdt.safety import HavError, daily_exposure
from bim2rdt.safety.analysis import Recording, analyze_recording, plot_day, read_accel_csv
from bim2rdt.sim.vibration import session_signal

from hav_helpers import T0

FS = 2000.0


def test_a_recording_that_ends_mid_activity_ends_it_at_its_last_sample():
    signal = session_signal([("idle", 2), ("grinder", 20)], FS, a_hv={"grinder": 6.0})
    report = analyze_recording(Recording(T0, FS, signal))
    (activity,) = report.activities
    assert activity["ended"] - T0 == pytest.approx(22.0, abs=1e-6)
    assert report.a8 == pytest.approx(daily_exposure(6.0, 20.0), rel=0.05) and report.rejected_s == 0.0


def test_nan_samples_are_rejected_and_the_report_says_how_long():
    signal = session_signal([("idle", 2), ("grinder", 20)], FS, a_hv={"grinder": 6.0})
    signal[int(10 * FS):int(10.01 * FS), 1] = np.nan  # 10 ms of dropped samples, 8 s into the grinding
    report = analyze_recording(Recording(T0, FS, signal))
    assert report.rejected_s == pytest.approx(1.0)  # the NaN block and the settling block after it, 0.5 s each
    assert report.rejected_kinds == ["nan", "settling"]
    assert report.trigger_s == pytest.approx(19.0, abs=0.01) and np.isfinite(report.a8)


def test_a_header_without_samples_is_refused_in_one_line_without_a_warning(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("t,ax,ay,az\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's 'input contained no data' would be a second line on stderr
        with pytest.raises(HavError, match="only 0 samples"):
            read_accel_csv(path)


def test_a_recording_sampled_below_every_wh_band_is_refused(tmp_path):
    path = tmp_path / "slow.csv"
    path.write_text("t,ax,ay,az\n" + "".join(f"{i / 10},1,1,1\n" for i in range(100)))
    with pytest.raises(HavError, match="10 Hz"):
        read_accel_csv(path)


@pytest.mark.parametrize("make, message", [(lambda p: p.mkdir(), "not a file"),
                                           (lambda p: p.write_bytes(b"\xff\xfe\x00\x01 binary"), "not a text CSV")])
def test_a_folder_or_a_binary_file_is_refused_in_one_line(tmp_path, make, message):
    path = tmp_path / "day.csv"
    make(path)
    with pytest.raises(HavError, match=message):
        read_accel_csv(path)


def test_a_plot_that_cannot_be_written_is_a_hav_error(tmp_path):
    (tmp_path / "taken").write_text("a file where the plot folder should be")
    report = analyze_recording(Recording(T0, FS, session_signal([("grinder", 3)], FS)))
    with pytest.raises(HavError, match="cannot write the plot"):
        plot_day(report, tmp_path / "taken" / "day.png")
