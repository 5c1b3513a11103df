"""From a reader's arrays to a checked :class:`~bim2rdt.perception.Frame`: scale, units, intrinsics, calibration.

Every frame reader ends here, so units are checked in one place where data enters: raw depth is divided by the
units per metre, a depth that still looks like millimetres is refused (naming ``depth_scale``), the intrinsics
are the caller's override or the recording's (else refused), and the optional depth correction is applied.
"""

from __future__ import annotations

import numpy as np

from bim2rdt.perception import Frame, Intrinsics, PerceptionError
from bim2rdt.sources.calibration import correct_depth
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.options import SourceOptions

MAX_MEDIAN_DEPTH_M = 20.0
"""An RGB-D frame whose median depth exceeds this (m) after scaling has the wrong scale: RGB-D cameras range
well under 20 m, and a millimetre depth read as metres gives hundreds to thousands."""


def intrinsics_for(path, options: SourceOptions, width: int, height: int,
                   found: Intrinsics | None) -> Intrinsics:
    """The caller's intrinsics if given (a dict takes the image's size unless it names one), else the
    recording's ``found``; :class:`SourceError` if neither, or if their size is not the image's."""
    given = options.intrinsics
    if isinstance(given, dict):
        given = Intrinsics(**{"width": width, "height": height, **{k: float(v) for k, v in given.items()
                                                                  if k not in ("width", "height")},
                              **{k: int(v) for k, v in given.items() if k in ("width", "height")}})
    intrinsics = given if given is not None else found
    if intrinsics is None:
        raise SourceError(path, "no camera intrinsics in the recording; give them (intrinsics=dict(fx=.., fy=.., "
                                "cx=.., cy=..); bim2rdt verify --intrinsics FILE.json)")
    if (intrinsics.width, intrinsics.height) != (width, height):
        raise SourceError(path, f"the intrinsics are for {intrinsics.width}x{intrinsics.height} but the depth image "
                                f"is {width}x{height} (intrinsics, verify --intrinsics: give width and height)")
    return intrinsics


def depth_metres(path, raw: np.ndarray, units_per_metre: float) -> np.ndarray:
    """Raw depth (H, W) -> float32 metres (0 and non-finite = no return), refused when it is not numeric or its
    median still looks like millimetres."""
    raw = np.asarray(raw)
    if raw.ndim != 2:
        raise SourceError(path, f"depth must be one channel (H, W), got shape {raw.shape}")
    if raw.dtype.kind not in "iuf":
        raise SourceError(path, f"depth must be numeric, got dtype {raw.dtype}")
    depth = raw.astype(np.float32) / np.float32(units_per_metre)
    valid = depth[np.isfinite(depth) & (depth > 0)]
    if valid.size == 0:
        raise SourceError(path, "the depth image has no valid pixel (all 0 or NaN)")
    median = float(np.median(valid[:: max(1, valid.size // 20_000)]))  # a 20k-pixel sample tells the unit
    if median > MAX_MEDIAN_DEPTH_M:
        raise SourceError(path, f"median depth {median:.0f} m at {units_per_metre:g} units per metre: the depth looks "
                                "like millimetres; give depth_scale=1000 (bim2rdt verify --depth-scale 1000)")
    return depth


def build_frame(path, rgb: np.ndarray | None, depth_m: np.ndarray, intrinsics: Intrinsics, options: SourceOptions,
                *, time: float | None = None, prior: np.ndarray | None = None, up=None,
                source: str | None = None) -> Frame:
    """The checked frame: colour (a grey stand-in when the recording has none), depth in metres with the
    options' depth correction, the prior pose (the recording's, else the options'), and ``up`` (the options',
    else the recording's IMU). A frame the perception layer refuses becomes a :class:`SourceError`."""
    if rgb is None:
        rgb = np.full((*depth_m.shape, 3), 128, np.uint8)
    rgb = np.asarray(rgb)
    if rgb.shape[:2] != depth_m.shape:
        raise SourceError(path, f"colour is {rgb.shape[1]}x{rgb.shape[0]} but depth is "
                                f"{depth_m.shape[1]}x{depth_m.shape[0]}: they must be registered to one image")
    if options.depth_correction is not None:
        depth_m = correct_depth(depth_m, intrinsics, options.depth_correction)
    prior = prior if prior is not None else options.prior
    up = options.up if options.up is not None else up
    try:
        return Frame(rgb, depth_m, intrinsics, prior, pose_is_prior=prior is not None, time=time, up=up,
                     source=source or str(path))
    except PerceptionError as error:
        raise SourceError(path, str(error)) from None
