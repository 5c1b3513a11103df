"""TUM RGB-D recordings: a folder with ``rgb.txt`` and ``depth.txt`` (and optionally ``groundtruth.txt`` or
``associations.txt``), or a single colour + depth PNG pair.

- Lists: ``timestamp filename`` per line, ``#`` comments. Colour and depth are paired by the closest timestamp
  within ``MAX_PAIR_GAP_S`` (TUM's own ``associate.py`` rule); ``associations.txt`` (``t_rgb rgb t_depth depth``)
  pairs them instead when present.
- Depth: 16-bit PNG, 5000 units per metre (``depth_scale`` overrides); 0 = no return.
- Intrinsics: TUM's default for its registered depth (fx = fy = 525, cx = 319.5, cy = 239.5) unless given; the
  sequence-specific values (fr1/fr2/fr3) are the caller's to pass.
- ``groundtruth.txt`` (``t tx ty tz qx qy qz qw``, the colour camera in the motion-capture world) gives each frame
  the closest pose within ``MAX_PAIR_GAP_S`` as its prior.
- A pair folder (no rgb.txt): ``NAME_color.png`` + ``NAME_depth.png`` (or ``_rgb``/``_depth``). TUM's own sample
  pair (``TUM_color.png``/``TUM_depth.png``) takes TUM's scale and intrinsics; any other pair needs
  ``depth_scale`` and ``intrinsics``, or the folder's ``intrinsics.json`` ({"fx", "fy", "cx", "cy"}, optionally
  "depth_scale"), because nothing else tells them.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from bim2rdt.perception import Frame
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.frames import build_frame, depth_metres, intrinsics_for
from bim2rdt.sources.images import read_colour, read_depth_png
from bim2rdt.sources.options import SourceOptions

TUM_UNITS_PER_METRE = 5000.0
TUM_DEFAULT_INTRINSICS = dict(fx=525.0, fy=525.0, cx=319.5, cy=239.5)
MAX_PAIR_GAP_S = 0.02


def is_tum_folder(path: Path) -> bool:
    return (path / "rgb.txt").is_file() and (path / "depth.txt").is_file()


def is_pair_folder(path: Path) -> bool:
    return bool(_pairs(path))


class TumFolder:
    """A :class:`~bim2rdt.sources.FrameSource` over a TUM RGB-D sequence folder."""

    def __init__(self, path: Path, options: SourceOptions) -> None:
        self.path, self.options = Path(path), options
        self.pairs = _associations(self.path)
        if not self.pairs:
            raise SourceError(self.path, "no frames: no colour and depth image within "
                                         f"{MAX_PAIR_GAP_S * 1000:.0f} ms of each other in rgb.txt and depth.txt")
        self.poses = _groundtruth(self.path / "groundtruth.txt")

    def __iter__(self) -> Iterator[Frame]:
        options = _with_default_intrinsics(self.options)
        for count, (time_s, rgb_file, depth_file) in enumerate(self.pairs):
            if self.options.max_frames is not None and count >= self.options.max_frames:
                return
            yield _frame(self.path / rgb_file, self.path / depth_file, options,
                         self.options.depth_scale or TUM_UNITS_PER_METRE, time_s, _closest(self.poses, time_s))


class PairFolder:
    """A :class:`~bim2rdt.sources.FrameSource` over colour + depth PNG pairs in a folder (no timestamps)."""

    def __init__(self, path: Path, options: SourceOptions) -> None:
        self.path = Path(path)
        self.pairs = _pairs(self.path)
        options = _with_folder_intrinsics(self.path, options)
        tum_sample = all(colour.name.startswith("TUM_") for colour, _ in self.pairs)
        if tum_sample:
            options = _with_default_intrinsics(options)
            options = options if options.depth_scale else replace(options, depth_scale=TUM_UNITS_PER_METRE)
        if options.depth_scale is None:
            raise SourceError(self.path, "the depth PNGs' units are unknown: give depth_scale (units per metre: "
                                         "1000 for millimetres, 5000 for TUM; bim2rdt verify --depth-scale S), or put it in "
                                         "intrinsics.json")
        self.options = options

    def __iter__(self) -> Iterator[Frame]:
        for count, (colour, depth) in enumerate(self.pairs):
            if self.options.max_frames is not None and count >= self.options.max_frames:
                return
            yield _frame(colour, depth, self.options, self.options.depth_scale, None, None)


def _frame(colour_path: Path, depth_path: Path, options: SourceOptions, units_per_metre: float,
           time_s: float | None, prior: np.ndarray | None) -> Frame:
    rgb = read_colour(colour_path)
    depth = depth_metres(depth_path, read_depth_png(depth_path), units_per_metre)
    height, width = depth.shape
    if rgb.shape[:2] != depth.shape:
        raise SourceError(depth_path, f"depth is {width}x{height} but its colour image {colour_path.name} is "
                                      f"{rgb.shape[1]}x{rgb.shape[0]}")
    intrinsics = intrinsics_for(depth_path, options, width, height, None)
    return build_frame(depth_path, rgb, depth, intrinsics, options, time=time_s, prior=prior,
                       source=f"{depth_path.parent.name}/{depth_path.name}")


def _with_default_intrinsics(options: SourceOptions) -> SourceOptions:
    return options if options.intrinsics is not None else replace(options, intrinsics=dict(TUM_DEFAULT_INTRINSICS))


def _with_folder_intrinsics(folder: Path, options: SourceOptions) -> SourceOptions:
    path = folder / "intrinsics.json"
    if options.intrinsics is not None or not path.is_file():
        return options
    try:
        data = json.loads(path.read_text())
        given = {k: float(data[k]) for k in ("fx", "fy", "cx", "cy")}
        scale = float(data["depth_scale"]) if "depth_scale" in data else None
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise SourceError(path, f"needs fx, fy, cx, cy as numbers ({type(error).__name__}: {error})") from None
    return replace(options, intrinsics=given, depth_scale=options.depth_scale or scale)


def _pairs(folder: Path) -> list[tuple[Path, Path]]:
    """(colour, depth) PNG pairs by name: NAME_depth.png with NAME_color.png, NAME_colour.png or NAME_rgb.png."""
    pairs = []
    for depth in sorted(folder.glob("*_depth.png")):
        stem = depth.name[: -len("_depth.png")]
        colour = next((folder / f"{stem}_{tag}.png" for tag in ("color", "colour", "rgb")
                       if (folder / f"{stem}_{tag}.png").is_file()), None)
        if colour is not None:
            pairs.append((colour, depth))
    return pairs


def _read_list(path: Path, columns: int) -> list[list[str]]:
    try:
        lines = path.read_text().splitlines()
    except OSError as error:
        raise SourceError(path, f"cannot read ({error.strerror or error})") from None
    rows = []
    for number, line in enumerate(lines, 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        if len(parts) < columns:
            raise SourceError(path, f"line {number} has {len(parts)} fields, expected {columns}")
        rows.append(parts)
    return rows


def _stamp(path: Path, text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise SourceError(path, f"{text!r} is not a timestamp in seconds") from None


def _associations(folder: Path) -> list[tuple[float, str, str]]:
    """(time s, colour file, depth file) per frame, in time order."""
    listed = folder / "associations.txt"
    if listed.is_file():
        return [(_stamp(listed, r[0]), r[1], r[3]) for r in _read_list(listed, 4)]
    colours = [(_stamp(folder / "rgb.txt", r[0]), r[1]) for r in _read_list(folder / "rgb.txt", 2)]
    depths = [(_stamp(folder / "depth.txt", r[0]), r[1]) for r in _read_list(folder / "depth.txt", 2)]
    if not colours:
        return []
    colour_times = np.array([t for t, _ in colours])
    pairs, used = [], set()
    for time_s, depth_file in depths:
        k = int(np.argmin(np.abs(colour_times - time_s)))
        if abs(colour_times[k] - time_s) <= MAX_PAIR_GAP_S and k not in used:
            used.add(k)
            pairs.append((time_s, colours[k][1], depth_file))
    return pairs


def _groundtruth(path: Path) -> list[tuple[float, np.ndarray]]:
    if not path.is_file():
        return []
    poses = []
    for row in _read_list(path, 8):
        values = [_stamp(path, v) for v in row[:8]]
        T = np.eye(4)
        T[:3, :3] = Rotation.from_quat(values[4:8]).as_matrix()  # TUM stores qx qy qz qw, scipy's order
        T[:3, 3] = values[1:4]
        poses.append((values[0], T))
    return poses


def _closest(poses: list[tuple[float, np.ndarray]], time_s: float) -> np.ndarray | None:
    if not poses:
        return None
    gaps = [abs(t - time_s) for t, _ in poses]
    k = int(np.argmin(gaps))
    return poses[k][1] if gaps[k] <= MAX_PAIR_GAP_S else None


