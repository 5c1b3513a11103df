"""Each frame's two pictures for the report: its image with the outlines of the elements it saw, and its heat map
(the one another stage left in ``deviation/`` for it, else the depth residual against the BIM, :mod:`.overlay`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.twin import ElementState
from bim2rdt.verify.report.capture import FrameView
from bim2rdt.verify.report.overlay import RESIDUAL_SCALE_M, heat_png, outlined_png, residual_m
from bim2rdt.verify.report.page import MAX_FRAME_CARDS, FramePictures, frame_heat
from bim2rdt.verify.report.topics import outline_of


def frame_residuals(frames: Sequence, model: BimModel, views: Mapping[int, FrameView],
                    limit: int = MAX_FRAME_CARDS) -> dict[int, np.ndarray]:
    """Each localized frame's depth residual against the BIM (:func:`~.overlay.residual_m`), for the first
    ``limit`` frames with a copy.

    Args:
        frames: verify's frame results.
        model: The BIM.
        views: The frames' small copies by index.
        limit: Frames at most.

    Returns:
        Frame index -> (h, w) residuals, metres.
    """
    from bim2rdt.localization import OccludedMap

    chosen = [f for f in frames if f.index in views and f.accepted and f.pose is not None][:limit]
    if not chosen:
        return {}
    bim = OccludedMap.of(model).mesh
    return {f.index: residual_m(views[f.index].depth, views[f.index].intrinsics, f.pose, bim) for f in chosen}


def frame_pictures(frames: Sequence, states: Mapping[str, ElementState], model: BimModel,
                   views: Mapping[int, FrameView], residuals: Mapping[int, np.ndarray],
                   heat: Mapping[str, bytes]) -> dict[int, FramePictures]:
    """The pictures of every frame that has a copy and a residual, and the image alone of a frame not localized.

    Args:
        frames: verify's frame results.
        states: The twin's states by GlobalId.
        model: The BIM.
        views: The frames' small copies by index.
        residuals: :func:`frame_residuals`.
        heat: Heat maps another stage wrote (PNG by file name): a frame's own replaces its residual map.

    Returns:
        Frame index -> its pictures.
    """
    out = {}
    for frame in frames:
        view = views.get(frame.index)
        if view is not None and not frame.accepted and len(out) < MAX_FRAME_CARDS:
            out[frame.index] = FramePictures(outlined_png(view.rgb, view.intrinsics, np.eye(4), []))  # as recorded
        if frame.index not in residuals:
            continue
        outlines = [o for o in (outline_of(states[g], model) for g in in_view(frame, states) if g in states) if o]
        pictures = FramePictures(outlined_png(view.rgb, view.intrinsics, frame.pose, outlines))
        pictures.heat = frame_heat(heat, frame.index)
        if pictures.heat is not None:
            pictures.heat_note = "deviation heat map (deviation/)"
        else:
            pictures.heat = heat_png(residuals[frame.index])
            pictures.heat_note = (f"depth minus the BIM's on each ray: blue in front, red behind (±"
                                  f"{100 * RESIDUAL_SCALE_M:.0f} cm), grey no data")
        out[frame.index] = pictures
    return out


def in_view(frame, states: Mapping[str, ElementState]) -> list[str]:
    """GlobalIds of the elements the frame judged: its planned objects, the places it saw empty, and the new
    objects whose evidence names it.

    Args:
        frame: A verify frame result.
        states: The twin's states by GlobalId.

    Returns:
        The GlobalIds.
    """
    ids = {o.global_id for o in frame.observations if o.global_id is not None} | set(frame.missing)
    ids |= {g for g, s in states.items() if not s.in_bim and s.evidence and frame.index in s.evidence.frames}
    return sorted(ids)
