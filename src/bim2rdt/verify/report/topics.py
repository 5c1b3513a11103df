"""Which frame each issue is shown from: the BCF topic's viewpoint is the pose of the sensor that saw the element,
with that sensor's field of view, and its snapshot is that frame's image with the element outlined. A scan (no
image) gets a view from the scanner's position toward the element, rendered."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from datetime import datetime, timezone

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.perception import CameraError, look_at
from bim2rdt.twin import STATUS_COLOURS, ElementState
from bim2rdt.twin import ISSUES, TopicView, vertical_fov_deg
from bim2rdt.verify.report.capture import FrameView
from bim2rdt.verify.report.overlay import Outline, outlined_png
from bim2rdt.verify.report.plan import measured_vertices

SCAN_FOV_DEG = 60.0
"""The field of view of a scan's rendered viewpoint (a scanner sees all round; a viewer needs a cone)."""


def frame_words(frame) -> str:
    """Where and when a frame was taken, in words: "frame 3 (office1.pcd) at 2026-05-01T10:00:00+00:00", or
    "..., time unknown" for a frame without a timestamp.

    Args:
        frame: A verify frame result (``index``, ``source``, ``time`` UTC seconds or None).

    Returns:
        The words.
    """
    where = f"frame {frame.index} ({frame.source})"
    if frame.time is None:
        return f"{where}, time unknown"
    return f"{where} at {datetime.fromtimestamp(frame.time, timezone.utc).isoformat(timespec='seconds')}"


def element_vertices(state: ElementState, model: BimModel) -> np.ndarray | None:
    """The body to outline: where it was measured, else where the BIM puts it (a missing element).

    Args:
        state: The twin's state.
        model: The BIM.

    Returns:
        (N, 3) world vertices (metres), or None when there is no body.
    """
    measured = measured_vertices(state, model)
    if measured is not None:
        return measured
    if state.in_bim and model.has_mesh(state.global_id):
        return model.mesh(state.global_id)[0]
    return None


def outline_of(state: ElementState, model: BimModel) -> Outline | None:
    """The element's outline in its status colour, labelled by family (or class), or None without a body.

    Args:
        state: The twin's state.
        model: The BIM.

    Returns:
        The outline, or None.
    """
    import matplotlib.colors

    vertices = element_vertices(state, model)
    if vertices is None:
        return None
    rgb = tuple(int(255 * c) for c in matplotlib.colors.to_rgb(STATUS_COLOURS[state.status]))
    return Outline(vertices, rgb, f"{state.family or state.ifc_class or 'object'}: {state.status.value}")


def seen_from(state: ElementState, frames: Sequence) -> object | None:
    """The localized frame the element was seen from: the one whose pose is the evidence's camera, else the last
    of the evidence's frames that was localized.

    Args:
        state: The twin's state.
        frames: verify's frame results.

    Returns:
        The frame result, or None.
    """
    if state.evidence is None:
        return None
    by_index = {f.index: f for f in frames if f.accepted and f.pose is not None}
    candidates = [by_index[i] for i in state.evidence.frames if i in by_index]
    camera = state.evidence.camera
    for frame in candidates:
        if camera is not None and np.allclose(frame.pose, camera):
            return frame
    return candidates[-1] if candidates else None


def topic_views(states: Mapping[str, ElementState], frames: Sequence, views: Mapping[int, FrameView],
                model: BimModel) -> dict[str, TopicView]:
    """A BCF view for each deviating, missing or new element seen in a localized frame.

    Args:
        states: The twin's states by GlobalId.
        frames: verify's frame results.
        views: The frames' small copies by index (none for a scan).
        model: The BIM.

    Returns:
        GlobalId -> the view.
    """
    out = {}
    for state in states.values():
        frame = seen_from(state, frames) if state.status in ISSUES else None
        if frame is None:
            continue
        view, outline = views.get(frame.index), outline_of(state, model)
        if view is not None:
            png = outlined_png(view.rgb, view.intrinsics, frame.pose, [outline] if outline else [])
            out[state.global_id] = TopicView(frame.pose, vertical_fov_deg(view.intrinsics), png, frame_words(frame))
        else:
            out[state.global_id] = TopicView(_toward(frame.pose, outline), SCAN_FOV_DEG, None, frame_words(frame))
    return out


def _toward(T_world_sensor: np.ndarray, outline: Outline | None) -> np.ndarray:
    """A camera at the scanner's position looking at the element (the scanner's own axes without a body)."""
    if outline is None:
        return T_world_sensor
    try:
        return look_at(T_world_sensor[:3, 3], outline.vertices_world.mean(axis=0))
    except CameraError:
        return T_world_sensor

