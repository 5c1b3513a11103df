"""Recordings of tri-axial acceleration as CSV files: read one for ``hav analyze``, write one from a simulator.

The CSV (UTF-8, with or without a byte-order mark) has a header with a time column (``t`` or ``time``, seconds;
epoch or from 0) and three acceleration columns (``ax, ay, az`` or ``x, y, z``). Time must increase on every
row (a shuffled file is refused with the row). The sampling rate is the median time step.

Units are checked, not assumed: a body-worn or tool-mounted sensor always sees gravity, so the static
acceleration (the median over one-second windows of the magnitude of the mean vector) is ~9.81 in m/s^2 and ~1 in
g. Data in g is converted with a note; anything else (say, counts or a wrong scale) is refused unless the units are
given; data without any gravity (already high-passed) is read as m/s^2 with a note that it could not be checked.
Units given that gravity contradicts (``--units m/s2`` on data in g, or the reverse) are used, with a note.
"""

from __future__ import annotations

import csv
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bim2rdt.safety.errors import HavError
from bim2rdt.safety.weighting import require_weighable_rate

TIME_NAMES, AXIS_NAMES = ("t", "time", "time_s"), (("ax", "ay", "az"), ("x", "y", "z"))
GRAVITY = 9.80665
UNITS = ("auto", "m/s2", "g")
METRES_RANGE, G_RANGE = (7.0, 12.5), (0.7, 1.3)
"""Static acceleration that says m/s^2 or g (a tilted or moving sensor still shows most of gravity)."""
NO_GRAVITY = 0.2
"""Below this static acceleration (either unit) the data holds no gravity: its units cannot be checked."""


@dataclass
class Recording:
    """Samples ``xyz`` (n, 3) m/s^2 at ``fs`` Hz starting at ``t0`` (s); ``units`` says what the file held and
    ``notes`` what reading it changed or could not check."""

    t0: float
    fs: float
    xyz: np.ndarray
    units: str = "m/s2"
    notes: list[str] = field(default_factory=list)


def read_accel_csv(path: Path, units: str = "auto") -> Recording:
    """Read a CSV recording (``units``: 'auto' checks them, 'm/s2' or 'g' says them); HavError with the reason
    (and the row, for time going back) if it is not one."""
    if units not in UNITS:
        raise HavError(f"units must be one of {', '.join(UNITS)}, got {units!r}")
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
    steps = _increasing(path, data[:, 0])
    step = float(np.median(steps))
    fs = round(1.0 / step, 6)
    try:
        require_weighable_rate(fs)
    except HavError as error:
        raise HavError(f"{path}: {error} (is the time column in seconds?)") from None
    notes = [f"the time column has gaps (the longest {steps.max():.3g} s): the samples are weighed as one "
             f"continuous stream"] if steps.max() > 2.5 * step else []
    xyz, held = _in_metres(path, data[:, 1:4], fs, units, notes)
    return Recording(float(data[0, 0]), fs, xyz, held, notes)


def _increasing(path: Path, t: np.ndarray) -> np.ndarray:
    """The time steps; HavError naming the first data row where time does not increase."""
    steps = np.diff(t)
    back = np.flatnonzero(~(steps > 0))
    if back.size:
        row = int(back[0]) + 1
        raise HavError(f"{path}: time does not increase at data row {row + 1} ({t[row]:g} s after {t[row - 1]:g} s):"
                       " sort the recording by time")
    return steps


def static_acceleration(xyz: np.ndarray, fs: float) -> float:
    """The median over one-second windows of |mean acceleration vector|: gravity, in the file's units."""
    window = max(1, int(fs))
    count = max(1, xyz.shape[0] // window)
    means = xyz[:count * window].reshape(count, -1, 3).mean(axis=1) if xyz.shape[0] >= window else xyz.mean(0)[None]
    return float(np.median(np.linalg.norm(means, axis=1)))


def _contradicted(units: str, gravity: float, notes: list[str]) -> None:
    """A note when gravity says the other unit than the one given (the user's word stands, with a warning)."""
    looks = "g" if G_RANGE[0] <= gravity <= G_RANGE[1] else "m/s2" if METRES_RANGE[0] <= gravity <= METRES_RANGE[1] \
        else None
    if looks is not None and looks != units:
        notes.append(f"--units {units} given, but the static acceleration is {gravity:.2f}, which is gravity in "
                     f"{looks}: if the file holds {looks}, A(8) is off by a factor of {GRAVITY:.2f}")


def _in_metres(path: Path, xyz: np.ndarray, fs: float, units: str, notes: list[str]) -> tuple[np.ndarray, str]:
    """``xyz`` in m/s^2 and what the file held ('m/s2' or 'g'), checked by gravity when ``units`` is 'auto'."""
    gravity = static_acceleration(xyz, fs)
    if units != "auto":
        _contradicted(units, gravity, notes)
        return (xyz * GRAVITY, "g") if units == "g" else (xyz, "m/s2")
    if METRES_RANGE[0] <= gravity <= METRES_RANGE[1]:
        return xyz, "m/s2"
    if G_RANGE[0] <= gravity <= G_RANGE[1]:
        notes.append(f"the static acceleration is {gravity:.2f}: read as g and converted to m/s² "
                     "(give --units m/s2 if that is wrong)")
        return xyz * GRAVITY, "g"
    if gravity < NO_GRAVITY and np.sqrt(np.mean(xyz**2)) < 5000.0:
        notes.append(f"no gravity on any axis (static acceleration {gravity:.3g}): the units could not be checked; "
                     "read as m/s² (give --units g if they are g)")
        return xyz, "m/s2"
    raise HavError(f"{path}: the static acceleration is {gravity:.3g}, neither ~9.81 (m/s²) nor ~1 (g): check the "
                   "units, or give --units m/s2 or --units g")


def _header(path: Path) -> list[str]:
    """The CSV's first row, lower-cased; HavError if the path is no readable text file."""
    if not path.exists():
        raise HavError(f"no such file: {path}")
    if not path.is_file():
        raise HavError(f"{path}: not a file")
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:  # a byte-order mark is no part of a name
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
