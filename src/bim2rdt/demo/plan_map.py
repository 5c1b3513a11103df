"""The plan map: one picture of the robot's world on a storey, for reports (``report.md``, the HTML report) and
``bim2rdt plan --out``.

It draws, from the bottom up: where there is no floor (pale), the BIM's structure and objects in the robot's band
(dark grey) with the robot-radius margin around them (light grey), keep-out zones (red) and workers' circles
(orange), site objects coloured by their twin status, the robot's paths (planned: blue; replanned legs: dashed
red) and its stations (numbered triangles pointing where the camera looks).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from bim2rdt.planning import OccupancyGrid  # noqa: E402
from bim2rdt.twin import ElementStatus  # noqa: E402

STATUS_COLOURS = {ElementStatus.AS_PLANNED.value: "tab:green", ElementStatus.DEVIATING.value: "tab:orange",
                  ElementStatus.NEW.value: "tab:red", ElementStatus.MISSING.value: "tab:purple",
                  ElementStatus.UNVERIFIED.value: "tab:grey", ElementStatus.NOT_OBSERVED.value: "white",
                  ElementStatus.NOT_BUILT.value: "tab:brown",
                  "as-planned": "tab:green", "moved": "tab:orange"}
"""Fill colour per twin status (ElementStatus values; the mission's older verdict words map onto them)."""
_LAYERS = (("floor edge", (0.93, 0.91, 0.88, 1.0)), ("margin", (0.82, 0.82, 0.82, 1.0)),
           ("structure", (0.35, 0.35, 0.35, 1.0)), ("zone", (0.85, 0.15, 0.15, 0.35)),
           ("person", (1.0, 0.55, 0.0, 0.35)))


@dataclass(frozen=True)
class MapObject:
    """A site object on the map: its name, its plan outline (N, 2) world metres, its status (an ElementStatus
    value such as 'deviating'), and where the BIM planned it (outline, dashed) if it is a BIM element."""

    name: str
    outline_xy: np.ndarray
    status: str
    planned_xy: np.ndarray | None = None


def draw_plan_map(ax, grid: OccupancyGrid, *, paths: Sequence[np.ndarray] = (), replanned: Sequence[np.ndarray] = (),
                  stations: Sequence[np.ndarray] = (), objects: Sequence[MapObject] = (), title: str | None = None) -> None:
    """Draw the map onto matplotlib axes ``ax``. ``paths``/``replanned``: (N, 2) world metres each;
    ``stations``: camera poses (4x4 T_world_camera) or (x, y) points, numbered in visiting order."""
    ax.imshow(_layer_image(grid), origin="lower", extent=grid.frame.extent, interpolation="nearest", zorder=0)
    for thing in objects:
        if thing.planned_xy is not None:
            ax.plot(*np.vstack([thing.planned_xy, thing.planned_xy[:1]]).T, "--", color="0.25", lw=0.8, zorder=2)
        ax.fill(*thing.outline_xy.T, color=STATUS_COLOURS.get(str(thing.status), "tab:grey"), alpha=0.85,
                ec="black", lw=0.5, zorder=3)
    for path in paths:
        ax.plot(*np.asarray(path).T, "-", color="tab:blue", lw=1.6, zorder=4)
    for path in replanned:
        ax.plot(*np.asarray(path).T, "--", color="tab:red", lw=1.6, zorder=4)
    _draw_stations(ax, stations)
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)",
           title=title or f"Plan map: storey {grid.storey!r}, floor at {grid.floor_z:.2f} m")
    ax.legend(handles=_legend(grid, objects, bool(len(paths)), bool(len(replanned)), bool(len(stations))),
              loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)


def save_plan_map(grid: OccupancyGrid, path: Path, **kwargs) -> Path:
    """Draw the map (``draw_plan_map``'s keyword arguments) into a PNG at ``path``; returns ``path``."""
    width, height = grid.frame.extent[1] - grid.frame.extent[0], grid.frame.extent[3] - grid.frame.extent[2]
    scale = 9.0 / max(width, height)
    fig, ax = plt.subplots(figsize=(max(width * scale, 4.0) + 2.5, max(height * scale, 3.0) + 0.8))
    draw_plan_map(ax, grid, **kwargs)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def outline(points_xy: np.ndarray) -> np.ndarray:
    """The convex outline (K, 2) of plan points (N, 2), e.g. an object's mesh vertices at its pose."""
    from scipy.spatial import ConvexHull

    unique = np.unique(np.round(points_xy, 4), axis=0)
    return unique[ConvexHull(unique).vertices] if len(unique) >= 3 else unique


def _layer_image(grid: OccupancyGrid) -> np.ndarray:
    """RGBA (rows, cols, 4): one colour per layer, the later ones on top."""
    masks = {"floor edge": grid.layer(["floor edge"]), "margin": grid.blocked,
             "structure": grid.layer(["element", "door", "object"]), "zone": grid.layer(["zone"]),
             "person": grid.layer(["person"])}
    image = np.ones((*grid.frame.shape, 4))
    for name, colour in _LAYERS:
        mask = masks[name]
        alpha = colour[3]
        image[mask, :3] = (1 - alpha) * image[mask, :3] + alpha * np.asarray(colour[:3])
    return image


def _draw_stations(ax, stations: Sequence[np.ndarray]) -> None:
    for number, station in enumerate(stations, start=1):
        station = np.asarray(station, float)
        xy = station[:2, 3] if station.shape == (4, 4) else station[:2]
        ax.plot(*xy, "^", color="tab:blue", ms=7, mec="black", mew=0.5, zorder=5)
        if station.shape == (4, 4):
            view = station[:2, 2] / max(np.linalg.norm(station[:2, 2]), 1e-9)
            ax.annotate("", xy=xy + 0.6 * view, xytext=xy, arrowprops={"arrowstyle": "->", "color": "tab:blue"},
                        zorder=5)
        ax.annotate(str(number), xy, xytext=(4, 4), textcoords="offset points", fontsize=7, zorder=6)


def _legend(grid: OccupancyGrid, objects: Sequence[MapObject], paths: bool, replanned: bool, stations: bool) -> list:
    handles = [Patch(color=_LAYERS[2][1], label="walls, columns, objects (BIM)"),
               Patch(color=_LAYERS[1][1], label="robot radius margin")]
    kinds = {fp.kind for fp in grid.zones}
    if "zone" in kinds:
        handles.append(Patch(color=_LAYERS[3][1], label="keep-out zone"))
    if "person" in kinds:
        handles.append(Patch(color=_LAYERS[4][1], label="worker keep-out"))
    for status in dict.fromkeys(str(o.status) for o in objects):
        handles.append(Patch(color=STATUS_COLOURS.get(status, "tab:grey"), label=status))
    if paths:
        handles.append(Line2D([], [], color="tab:blue", label="robot path"))
    if replanned:
        handles.append(Line2D([], [], color="tab:red", ls="--", label="replanned"))
    if stations:
        handles.append(Line2D([], [], color="tab:blue", marker="^", ls="", label="stations"))
    return handles
