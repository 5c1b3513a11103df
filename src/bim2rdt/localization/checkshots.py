"""Check shots: each station's localization measured against BIM landmarks a field engineer can tape.

The paper asks for check shots (stair landings, core corners) "so the robot's localization can be
sanity-checked by field engineers". A landmark here is a vertical convex edge of a permanent element: a column
corner, a free wall end, the edge of a door opening. From the fixed camera pose, the depth points on the two
faces that meet at the edge locate it in plan: each face's points give its plane's offset (median of their
signed distances to the BIM face), and the two offsets solve for the edge's shift. The shift's length is the
landmark's residual; a station's residual is the root mean square over the landmarks it saw, flagged above
``flag_distance`` (3 cm). An engineer checks a flagged station by taping the distance from the robot to the
landmark (``tape`` is what the robot believes it to be).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

from bim2rdt.bim import BimModel, map_elements
from bim2rdt.localization.depth import depth_grid, grid_normals
from bim2rdt.localization.surfaces import PermanentMap, permanent_map
from bim2rdt.perception import Frame

KINDS = {"IfcColumn": "column corner", "IfcColumnStandardCase": "column corner", "IfcDoor": "door edge"}
"""What an engineer calls an element's vertical edge; walls' edges are 'wall edge' (ends and openings)."""
FACING_COS = np.cos(np.deg2rad(25.0))
"""A depth point belongs to a face only if its own normal is within 25 degrees of the face's."""


@dataclass(frozen=True)
class Landmark:
    """A vertical edge where two vertical faces of permanent elements meet: ``xy`` (2,) m in plan, from
    ``z_low`` to ``z_high`` m; per face its outward unit normal (2,), the direction (2,) it runs away from the
    edge and how far (m). Convex edges are column corners, wall ends and opening edges; concave ones are room
    corners where two faces meet (room corners, recesses). ``name`` says where and ``kind`` what it is."""

    name: str
    kind: str
    xy: np.ndarray
    z_low: float
    z_high: float
    normals: tuple[np.ndarray, np.ndarray]
    directions: tuple[np.ndarray, np.ndarray]
    widths: tuple[float, float]


@dataclass(frozen=True)
class CheckShot:
    """One landmark measured from a station: its ``shift`` (2,) in plan (m, observed minus BIM), ``residual``
    (its length), the depth points on each face, and ``tape``, the horizontal distance from the camera to the
    landmark that the robot believes (what an engineer tapes to check it)."""

    landmark: Landmark
    shift: np.ndarray
    residual: float
    points: tuple[int, int]
    tape: float


@dataclass(frozen=True)
class StationCheck:
    """Every landmark measured at a station, their RMS ``residual`` (m, NaN when none was seen) and whether it
    exceeds the flag distance."""

    shots: list[CheckShot] = field(default_factory=list)
    residual: float = float("nan")
    flagged: bool = False


@dataclass(frozen=True)
class CheckShotConfig:
    """``radius`` (m) around a landmark in which face points count, ``band`` (m) off a face within which they
    count, ``edge_margin`` (m) kept clear of the edge (mixed pixels), ``min_points`` per face, depth ``stride``,
    ``flag_distance`` (m) above which a station is flagged, ``min_height`` (m) of an edge to count."""

    radius: float = 0.6
    band: float = 0.1
    edge_margin: float = 0.03
    min_points: int = 12
    stride: int = 2
    flag_distance: float = 0.03
    min_height: float = 1.0


def landmarks(model: BimModel, min_height: float = 1.0) -> list[Landmark]:
    """The model's landmarks at least ``min_height`` m tall whose faces meet at 30 degrees or more: every convex
    vertical edge of a permanent element, and every inside corner between two of their vertical faces."""
    faces = []
    for element in map_elements(model):
        vertices, triangles = model.mesh(element.global_id)
        faces += _vertical_faces(trimesh.Trimesh(vertices, triangles), element, min_height)
    found = {}
    for a, b in zip(*np.triu_indices(len(faces), k=1)):
        for mark in _corners(faces[a], faces[b], min_height):
            found.setdefault((round(float(mark.xy[0]), 2), round(float(mark.xy[1]), 2), mark.kind), mark)
    return list(found.values())


@dataclass(frozen=True)
class _Face:
    """A vertical planar face in plan: outward normal n (2,), tangent t (2,), offset n.p, extent along t, z range."""

    label: str
    kind: str
    normal: np.ndarray
    tangent: np.ndarray
    offset: float
    along: tuple[float, float]
    z: tuple[float, float]


def _vertical_faces(mesh: trimesh.Trimesh, element, min_height: float) -> list[_Face]:
    kind = KINDS.get(element.ifc_class, "wall edge" if element.ifc_class.startswith("IfcWall") else
                     f"{element.ifc_class.removeprefix('Ifc').lower()} edge")
    faces = []
    for facet, normal in zip(mesh.facets, mesh.facets_normal):
        points = mesh.vertices[np.unique(mesh.faces[facet])]
        if abs(normal[2]) > 0.1 or np.ptp(points[:, 2]) < min_height:
            continue
        n = normal[:2] / np.linalg.norm(normal[:2])
        t = np.array([-n[1], n[0]])
        along = points[:, :2] @ t
        faces.append(_Face(element.name or element.global_id, kind, n, t, float(points[0, :2] @ n),
                           (float(along.min()), float(along.max())),
                           (float(points[:, 2].min()), float(points[:, 2].max()))))
    return faces


def _corners(a: _Face, b: _Face, min_height: float, tolerance: float = 0.01) -> list[Landmark]:
    """The edges where faces ``a`` and ``b`` meet: their lines cross within both, and each face, followed away
    from the crossing, lies wholly on one side of the other (convex, one element: both behind; concave: both in
    front). A face running on past the crossing (a wall meeting another mid-way) gives a corner on each side."""
    if abs(a.normal @ b.normal) > np.cos(np.deg2rad(30.0)):
        return []
    xy = np.linalg.solve(np.stack([a.normal, b.normal]), np.array([a.offset, b.offset]))
    z_low, z_high = max(a.z[0], b.z[0]), min(a.z[1], b.z[1])
    if z_high - z_low < min_height:
        return []
    found = []
    for d_a, w_a in _runs(a, xy, tolerance):
        for d_b, w_b in _runs(b, xy, tolerance):
            sides = (a.normal @ d_b, b.normal @ d_a)
            if min(sides) > 0.01:
                kind, label = "inside corner", f"{a.label} / {b.label}"
            elif max(sides) < -0.01 and a.label == b.label:
                kind, label = a.kind, a.label
            else:
                continue
            found.append(Landmark(f"{label} {kind} at ({xy[0]:.2f}, {xy[1]:.2f})", kind, xy, z_low, z_high,
                                  (a.normal, b.normal), (d_a, d_b), (w_a, w_b)))
    return found


def _runs(face: _Face, xy: np.ndarray, tolerance: float) -> list[tuple[np.ndarray, float]]:
    """(direction, length) of each part of the face that runs at least 5 cm away from the point ``xy`` on its
    line; none if the point is off the face."""
    s = xy @ face.tangent
    low, high = face.along
    if s < low - tolerance or s > high + tolerance:
        return []
    return [(sign * face.tangent, length) for sign, length in ((1.0, high - s), (-1.0, s - low)) if length >= 0.05]


def check_shots(frame: Frame, model: BimModel, T_world_camera: np.ndarray,
                config: CheckShotConfig = CheckShotConfig()) -> StationCheck:
    """Measure every landmark of ``model`` the frame sees from the fixed pose ``T_world_camera``; see the module
    docstring. A landmark counts only when both its faces are in view and not hidden behind other elements, and
    each face has at least ``config.min_points`` depth points on it.

    Args:
        frame: An RGB-D frame (depth in metres) with its camera intrinsics.
        model: The BIM model whose permanent elements give the landmarks.
        T_world_camera: (4, 4) the camera pose the station's localization fixed, metres.
        config: Where face points count, how many are needed, and the flag distance.

    Returns:
        The landmarks measured, their RMS residual (m; NaN when none was measured) and whether it exceeds
            ``config.flag_distance``.
    """
    surfaces = permanent_map(model)
    marks = [mark for mark in model_landmarks(model, config.min_height)
             if _in_sight(mark, T_world_camera, frame.intrinsics, surfaces)]
    grid = depth_grid(frame, config.stride, 0.3, 8.0)
    normals_cam = grid_normals(grid).reshape(-1, 3)
    good = np.all(np.isfinite(normals_cam), axis=1)
    points = grid.reshape(-1, 3)[good] @ T_world_camera[:3, :3].T + T_world_camera[:3, 3]
    normals = normals_cam[good] @ T_world_camera[:3, :3].T
    camera_xy = T_world_camera[:2, 3]
    shots = [shot for mark in marks if (shot := _measure(mark, points, normals, camera_xy, config)) is not None]
    if not shots:
        return StationCheck()
    residual = float(np.sqrt(np.mean([s.residual**2 for s in shots])))
    return StationCheck(shots, residual, residual > config.flag_distance)


def _measure(mark: Landmark, points: np.ndarray, normals: np.ndarray, camera_xy: np.ndarray,
             config: CheckShotConfig) -> CheckShot | None:
    """The landmark's shift from the points on its two faces (near the face's plane, facing its way: a door
    leaf set back behind a reveal is near the reveal's plane but faces across it), or None when either face is
    not seen well."""
    n1, n2 = mark.normals
    rel = points[:, :2] - mark.xy
    near = ((points[:, 2] > mark.z_low + 0.05) & (points[:, 2] < mark.z_high - 0.05)
            & (np.linalg.norm(rel, axis=1) < config.radius))
    offsets, counts = [], []
    for normal, direction, width in zip(mark.normals, mark.directions, mark.widths):
        along, beside = rel[near] @ normal, rel[near] @ direction
        facing = normals[near, :2] @ normal > FACING_COS
        on_face = (np.abs(along) < config.band) & (beside > config.edge_margin) & (beside < width) & facing
        counts.append(int(on_face.sum()))
        if counts[-1] < config.min_points:
            return None
        offsets.append(float(np.median(along[on_face])))
    shift = np.linalg.solve(np.stack([n1, n2]), np.array(offsets))
    return CheckShot(mark, shift, float(np.linalg.norm(shift)), (counts[0], counts[1]),
                     float(np.linalg.norm(mark.xy - camera_xy)))


def _in_sight(mark: Landmark, T_world_camera: np.ndarray, intrinsics, surfaces: PermanentMap) -> bool:
    """Both faces in front of the camera, in its image, and the first BIM surface on the ray to a point on each
    (a third of the way up, a little off the edge): a wall end buried in the wall it meets is not a landmark."""
    centre = T_world_camera[:3, 3]
    z = mark.z_low + (mark.z_high - mark.z_low) / 3.0
    probes = np.array([np.r_[mark.xy + min(0.1, 0.5 * width) * direction, z]
                       for direction, width in zip(mark.directions, mark.widths)])
    if any((centre[:2] - mark.xy) @ normal <= 0 for normal in mark.normals):
        return False  # the camera is behind one of the faces
    in_camera = (probes - centre) @ T_world_camera[:3, :3]
    if np.any(in_camera[:, 2] <= 0.3):
        return False
    u = intrinsics.fx * in_camera[:, 0] / in_camera[:, 2] + intrinsics.cx
    v = intrinsics.fy * in_camera[:, 1] / in_camera[:, 2] + intrinsics.cy
    if np.any((u < 0) | (u >= intrinsics.width) | (v < 0) | (v >= intrinsics.height)):
        return False
    directions = probes - centre
    first = surfaces.first_hit(centre, directions)
    return bool(np.all(first >= 1.0 - 0.02 / np.linalg.norm(directions, axis=1)))


_LANDMARKS: dict[tuple[str, int, float], list[Landmark]] = {}


def model_landmarks(model: BimModel, min_height: float = 1.0) -> list[Landmark]:
    """:func:`landmarks` of a model, computed once per model object."""
    key = (model.digest, id(model), min_height)
    if key not in _LANDMARKS:
        if len(_LANDMARKS) >= 4:
            _LANDMARKS.pop(next(iter(_LANDMARKS)))
        _LANDMARKS[key] = landmarks(model, min_height)
    return _LANDMARKS[key]
