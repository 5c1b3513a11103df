"""The report's facts of each element, read from the twin's state and verify's frames: its name, the shift of
its measured origin from the BIM's (x, y, z metres), the frames that saw it, and the reason for its status in
words."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.twin import ElementState, ElementStatus


@dataclass(frozen=True)
class ElementRow:
    """One element's line: ``name`` (the BIM's, '' for a new object), ``shift`` (3,) metres or None (not measured,
    or measured by a fit too poor to judge), ``frames`` (indices) and ``reason``."""

    state: ElementState
    name: str
    shift: np.ndarray | None
    frames: tuple[int, ...]
    reason: str


def element_rows(states: dict[str, ElementState], frames: Sequence, model: BimModel) -> list[ElementRow]:
    """A row per observed element (issues first: deviating, missing, new, unverified, then as planned).

    Args:
        states: The twin's states by GlobalId.
        frames: verify's frame results.
        model: The BIM.

    Returns:
        The rows.
    """
    seen: dict[str, set[int]] = {}
    notes: dict[str, str] = {}
    for frame in frames:
        for observation in frame.observations:
            if observation.global_id is not None:
                seen.setdefault(observation.global_id, set()).add(frame.index)
                if observation.reason:
                    notes[observation.global_id] = observation.reason
        for global_id in frame.missing:
            seen.setdefault(global_id, set()).add(frame.index)
    order = [ElementStatus.DEVIATING, ElementStatus.MISSING, ElementStatus.NEW, ElementStatus.UNVERIFIED,
             ElementStatus.AS_PLANNED]
    rows = []
    for state in sorted((s for s in states.values() if s.status in order),
                        key=lambda s: (order.index(s.status), s.family or "", s.global_id)):
        element = model.element(state.global_id) if state.in_bim else None
        shift = None
        if element is not None and state.pose is not None and state.status is not ElementStatus.UNVERIFIED:
            shift = np.asarray(state.pose)[:3, 3] - np.asarray(element.placement)[:3, 3]
        evidence = set(state.evidence.frames) if state.evidence else set()
        rows.append(ElementRow(state, (element.name or "") if element else "", shift,
                               tuple(sorted(seen.get(state.global_id, set()) | evidence)),
                               reason(state, notes.get(state.global_id, ""))))
    return rows


def reason(state: ElementState, note: str = "") -> str:
    """Why the element has its status, in words.

    Args:
        state: The twin's state.
        note: What verify said of its observation (a miscalibrated frame's reason), if anything.

    Returns:
        One sentence.
    """
    d, t, f = state.deviation, state.tolerance, state.fit
    if state.status is ElementStatus.MISSING:
        return "its place was seen empty"
    if state.status is ElementStatus.NEW:
        return "an object the BIM does not have"
    if state.status is ElementStatus.UNVERIFIED:
        if note:
            return note
        fitness = f"fitness {f.fitness:.2f}" if f else "no fit"
        return f"too few of its points on the body to judge ({fitness})"
    if d is None or t is None:
        return state.status.value
    bounds = f"the '{t.name}' tolerance ({100 * t.translation:.3g} cm, {t.rotation_deg:.3g}°)"
    if state.status is ElementStatus.AS_PLANNED:
        return f"within {bounds}"
    checks = ((f"off by {100 * d.translation:.1f} cm", d.translation > t.translation),
              (f"tilted {d.tilt_deg:.1f}°", d.tilt_deg > t.rotation_deg),
              (f"turned {abs(d.yaw_deg):.1f}°", abs(d.yaw_deg) > t.rotation_deg))
    words = [words for words, over in checks if over]
    return f"{', '.join(words) or 'outside'}: beyond {bounds}"
