"""The report's plan: the storey's section (the occupancy grid's walls, doors and floor edges), every site object
of the BIM drawn where the BIM puts it and coloured by its verdict (a deviating one also where it was measured,
dashed), new objects where they were found, and each localized frame's sensor: its position, its heading and its
2-sigma position ellipse, numbered as in the report's frame list.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Ellipse, Patch  # noqa: E402
from scipy.spatial import ConvexHull, QhullError  # noqa: E402

from bim2rdt.bim import BimModel  # noqa: E402
from bim2rdt.perception import movable_elements  # noqa: E402
from bim2rdt.planning import OccupancyGrid  # noqa: E402
from bim2rdt.twin import STATUS_COLOURS, ElementState, ElementStatus  # noqa: E402

PLAN_WIDTH_IN = 7.0
"""The plan's width in inches at 110 dpi (the legend gets 3 more); its height follows the storey's aspect."""
SIGMAS = 2.0
"""The ellipse is the 2-sigma contour of the fix's x-y covariance (~86 % of the probability in 2D)."""
MIN_ELLIPSE_M = 0.15
"""Ellipses are drawn enlarged so the largest is at least this wide (the factor is in the legend)."""
MAX_AXIS_M = 1.5
"""An ellipse axis longer than this (a direction the view left free: its sigma is metres or more) is drawn this
long, dashed."""


def plan_png(model: BimModel, states: Mapping[str, ElementState], frames: Sequence, grid: OccupancyGrid) -> bytes:
    """The plan as a PNG.

    Args:
        model: The BIM.
        states: The twin's states by GlobalId.
        frames: verify's frame results (``index``, ``accepted``, ``pose`` 4x4, ``covariance`` 6x6 over x, y, z
            and the rotations, world frame).
        grid: The storey's occupancy grid (its structure layers are the section).

    Returns:
        The PNG image.
    """
    x0, x1, y0, y1 = grid.frame.extent
    width = PLAN_WIDTH_IN * float(np.clip((x1 - x0) / (y1 - y0), 0.6, 1.0))  # a tall storey gets narrower
    fig, ax = plt.subplots(figsize=(width + 3.0, float(np.clip(width * (y1 - y0) / (x1 - x0) + 0.8, 3.0, 8.0))),
                           dpi=110)
    image = np.ones((*grid.frame.shape, 3))
    image[grid.layer(["floor edge"])] = 0.9
    image[grid.layer(["element", "door"])] = 0.3
    ax.imshow(image, origin="lower", extent=grid.frame.extent, interpolation="nearest", zorder=0)
    _elements(ax, model, states)
    factor = _sensors(ax, frames)
    ax.set(xlabel="x (m)", ylabel="y (m)", aspect="equal", xlim=(x0, x1), ylim=(y0, y1))
    ax.legend(handles=_legend(states, factor), loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", bbox_inches="tight")  # the legend outside the axes kept whole
    plt.close(fig)
    return buffer.getvalue()


def footprint(vertices_world: np.ndarray) -> np.ndarray | None:
    """The convex hull of a body's vertices seen from above, (K, 2) metres, or None for a degenerate one.

    Args:
        vertices_world: (N, 3) vertices, metres.

    Returns:
        The hull's corners in order, or None.
    """
    xy = np.unique(np.round(np.asarray(vertices_world, float)[:, :2], 4), axis=0)
    if len(xy) < 3:
        return None
    try:
        return xy[ConvexHull(xy).vertices]
    except QhullError:
        return None


def measured_vertices(state: ElementState, model: BimModel) -> np.ndarray | None:
    """The element's body where it was measured (world, metres): the BIM mesh moved by the measured pose, or a
    new object's own mesh at its pose; None without a measured pose.

    Args:
        state: The twin's state of the element.
        model: The BIM.

    Returns:
        (N, 3) world vertices, or None.
    """
    if state.pose is None:
        return None
    if state.mesh is not None:
        body = np.asarray(state.mesh[0], float)
        return body @ state.pose[:3, :3].T + state.pose[:3, 3]
    if state.in_bim and model.has_mesh(state.global_id):
        vertices, _ = model.mesh(state.global_id)
        move = state.pose @ np.linalg.inv(model.element(state.global_id).placement)
        return vertices @ move[:3, :3].T + move[:3, 3]
    return None


def _elements(ax, model: BimModel, states: Mapping[str, ElementState]) -> None:
    objects = {el.global_id for el in movable_elements(model)}  # walls and slabs are the section's
    for state in states.values():
        colour = STATUS_COLOURS[state.status]
        if state.global_id in objects:
            hull = footprint(model.mesh(state.global_id)[0])
            if hull is not None:
                ax.fill(*hull.T, color=colour, alpha=0.8, ec="black", lw=0.5, zorder=2)
        measured = measured_vertices(state, model)
        hull = None if measured is None else footprint(measured)
        if hull is not None and state.status in (ElementStatus.DEVIATING, ElementStatus.NEW):
            ax.fill(*hull.T, fill=state.status is ElementStatus.NEW, color=colour, ec=colour, lw=1.4,
                    ls="--" if state.in_bim else "-", alpha=0.9, zorder=3)


def _sensors(ax, frames: Sequence) -> float:
    fixed = [f for f in frames if f.accepted and f.pose is not None]
    widths = [min(_ellipse_axes(f.covariance)[0], MAX_AXIS_M) for f in fixed if f.covariance is not None]
    factor = max(1.0, MIN_ELLIPSE_M / max(widths)) if widths and max(widths) > 0 else 1.0
    for f in fixed:
        x, y = f.pose[:2, 3]
        heading = f.pose[:2, 2] / max(np.linalg.norm(f.pose[:2, 2]), 1e-9)
        if f.covariance is not None:
            width, height, angle = _ellipse_axes(f.covariance)
            free = width * factor > MAX_AXIS_M
            ax.add_patch(Ellipse((x, y), min(width * factor, MAX_AXIS_M), min(height * factor, MAX_AXIS_M),
                                 angle=angle, fc="tab:blue", alpha=0.25, ec="tab:blue", ls="--" if free else "-",
                                 zorder=4))
        ax.annotate("", (x + 0.6 * heading[0], y + 0.6 * heading[1]), (x, y),
                    arrowprops={"arrowstyle": "->", "color": "tab:blue", "lw": 1.5}, zorder=5)
        ax.plot(x, y, "o", color="tab:blue", ms=4, zorder=5)
        ax.text(x, y, f" {f.index}", fontsize=7, color="tab:blue", zorder=5)
    return factor


def _ellipse_axes(covariance) -> tuple[float, float, float]:
    """Full width, height (metres) and angle (degrees) of the 2-sigma ellipse of the x-y block."""
    C = np.asarray(covariance, float)[:2, :2]
    values, vectors = np.linalg.eigh((C + C.T) / 2)
    values = np.clip(values, 0.0, None)
    angle = float(np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1])))
    return 2 * SIGMAS * float(np.sqrt(values[1])), 2 * SIGMAS * float(np.sqrt(values[0])), angle


def _legend(states: Mapping[str, ElementState], factor: float) -> list:
    present = {s.status for s in states.values()}
    handles = [Patch(color=STATUS_COLOURS[s], label=s.value) for s in ElementStatus if s in present]
    handles += [Patch(fc="white", ec=STATUS_COLOURS[ElementStatus.DEVIATING], ls="--", label="where measured"),
                Patch(color="0.3", label="walls, columns, doors (section)"),
                Patch(color="0.9", label="no floor"),
                Line2D([], [], color="tab:blue", marker="o", label="sensor and heading"),
                Patch(color="tab:blue", alpha=0.25, label=f"2-sigma position{f' (x{factor:.0f})' if factor > 1 else ''}"),
                Patch(fc="white", ec="tab:blue", ls="--", label=f"a free direction (cut at {MAX_AXIS_M} m)")]
    return handles
