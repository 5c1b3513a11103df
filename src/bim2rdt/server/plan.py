"""The site plan as drawable outlines (world x, y in metres): structure, zones, elements by status and the robot's
path. Outlines are convex hulls of the meshes' plan projections: exact for the straight walls, columns, boxes and
zones of a site; an L-shaped element is drawn by its hull."""

from __future__ import annotations

import numpy as np

STRUCTURE = frozenset({"IfcWall", "IfcWallStandardCase", "IfcColumn", "IfcCurtainWall", "IfcDoor", "IfcWindow",
                       "IfcStair", "IfcStairFlight", "IfcRamp", "IfcBeam", "IfcRailing", "IfcPlate", "IfcMember"})
"""Classes drawn as the plan's fixed structure (grey), unless the robot observed them."""
FLOORS = frozenset({"IfcSlab", "IfcRoof", "IfcCovering"})
ZONES = frozenset({"IfcSpace", "IfcZone", "IfcSpatialZone"})


def hull_xy(points_world: np.ndarray) -> list[list[float]]:
    """The convex hull of points' (x, y), counter-clockwise, rounded to the millimetre."""
    from scipy.spatial import ConvexHull, QhullError

    xy = np.unique(np.round(np.asarray(points_world, dtype=float)[:, :2], 3), axis=0)
    if len(xy) < 3:
        return xy.tolist()
    try:
        return np.round(xy[ConvexHull(xy).vertices], 3).tolist()
    except QhullError:  # collinear: a segment
        return xy[[0, -1]].tolist()


def posed(vertices_body: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Body-frame vertices placed by a 4x4 T_world_model."""
    return np.asarray(vertices_body) @ pose[:3, :3].T + pose[:3, 3]


def robot_path(events) -> list[dict]:
    """Where the robot's camera was, in time order: one point per station it recorded an observation from (the
    evidence camera of each observation / missing record), consecutive repeats merged."""
    path: list[dict] = []
    for event in sorted(events, key=lambda e: (e.time, e.seq)):
        camera = (event.data.get("evidence") or {}).get("camera")
        if camera is None:
            continue
        x, y = float(camera[0][3]), float(camera[1][3])
        if path and abs(path[-1]["x"] - x) < 1e-3 and abs(path[-1]["y"] - y) < 1e-3:
            continue
        path.append({"x": round(x, 3), "y": round(y, 3), "time": event.time, "robot": event.source,
                     "station": (event.data.get("evidence") or {}).get("station")})
    return path


def bounds(outlines: list[list[list[float]]]) -> list[float]:
    """[xmin, ymin, xmax, ymax] over every outline (a 1 m square at the origin when there are none)."""
    points = [p for outline in outlines for p in outline]
    if not points:
        return [0.0, 0.0, 1.0, 1.0]
    array = np.asarray(points)
    return [float(array[:, 0].min()), float(array[:, 1].min()), float(array[:, 0].max()), float(array[:, 1].max())]
