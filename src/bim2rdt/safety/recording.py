"""Recordings of tri-axial acceleration as CSV files: read one for ``hav analyze``, write one from a simulator.

The CSV has a header with a time column (``t`` or ``time``, seconds; epoch or from 0) and three acceleration
columns (``ax, ay, az`` or ``x, y, z``, m/s^2). The sampling rate is the median time step.
"""

from __future__ import annotations

import csv
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bim2rdt.safety.errors import HavError
from bim2rdt.safety.weighting import require_weighable_rate

TIME_NAMES, AXIS_NAMES = ("t", "time", "time_s"), (("ax", "ay", "az"), ("x", "y", "z"))


@dataclass
class Recording:
    """Samples ``xyz`` (n, 3) m/s^2 at ``fs`` Hz starting at ``t0`` (s)."""

    t0: float
    fs: float
    xyz: np.ndarray


def read_accel_csv(path: Path) -> Recording:
    """Read a CSV recording; HavError with the reason if it is not one."""
    header = _header(Path(path))
    columns = _columns(header, path)
    try:
        with warnings.catch_warnings():  # 'input contained no data': the sample count below says it in one line
            warnings.simplefilter("ignore", UserWarning)
            data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=columns, ndmin=2)
    except ValueError as error:
        raise HavError(f"{path}: not numeric CSV data ({str(error).splitlines()[0]})") from None
    if data.shape[0] < 16:
        raise HavError(f"{path}: only {data.shape[0]} samples; a recording needs at least 16")
    step = float(np.median(np.diff(data[:, 0])))
    if not step > 0:
        raise HavError(f"{path}: the time column does not increase")
    fs = round(1.0 / step, 6)
    try:
        require_weighable_rate(fs)
    except HavError as error:
        raise HavError(f"{path}: {error} (is the time column in seconds?)") from None
    return Recording(float(data[0, 0]), fs, data[:, 1:4])


def _header(path: Path) -> list[str]:
    """The CSV's first row, lower-cased; HavError if the path is no readable text file."""
    if not path.exists():
        raise HavError(f"no such file: {path}")
    if not path.is_file():
        raise HavError(f"{path}: not a file")
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            return [name.strip().lower() for name in next(csv.reader(handle), [])]
    except UnicodeDecodeError:
        raise HavError(f"{path}: not a text CSV (it is not UTF-8)") from None


def _columns(header: list[str], path: Path) -> list[int]:
    time_col = next((header.index(n) for n in TIME_NAMES if n in header), None)
    axes = next((names for names in AXIS_NAMES if all(n in header for n in names)), None)
    if time_col is None or axes is None:
        raise HavError(f"{path}: the header needs a time column (t) and ax, ay, az (or x, y, z); got {header}")
    return [time_col, *(header.index(n) for n in axes)]


def write_accel_csv(path: Path, xyz: np.ndarray, fs: float, t0: float = 0.0) -> Path:
    """Write samples ``xyz`` (n, 3) m/s^2 at ``fs`` Hz from time ``t0`` (s) as a CSV :func:`read_accel_csv`
    reads; HavError in one line if the path cannot take it."""
    t = t0 + np.arange(xyz.shape[0]) / fs
    try:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        np.savetxt(path, np.column_stack([t, xyz]), delimiter=",", header="t,ax,ay,az", comments="",
                   fmt=["%.6f", "%.4f", "%.4f", "%.4f"])
    except OSError as error:
        raise HavError(f"cannot write {path}: {error.strerror or error}") from None
    return Path(path)
