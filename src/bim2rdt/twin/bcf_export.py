"""The twin's issues as BCF 2.1 (bcf-client): one topic per deviating, missing or new element.

Each topic selects the element (its GlobalId; a new object keeps the twin's GlobalId in the exported IFC), sets
the perspective camera it was seen from (the robot's camera when the recorder gave it, else a view from 4 m
off), and carries a snapshot rendered from that camera: the BIM around it in grey, the BIM pose in translucent
blue, and where the robot found it in the status colour. A caller that kept the frames (``verify``) passes a
:class:`TopicView` per element instead: the sensor's own pose and field of view, and that frame's image. BCF 2.1 is what BIM coordination tools (Revit's BCF
Manager, Solibri, BIMcollab, BlenderBIM) all open.
"""

from __future__ import annotations

import tempfile
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from bcf.v2 import model as bcf_model
from bcf.v2.bcfxml import BcfXml
from bcf.v2.visinfo import VisualizationInfoHandler

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.bim import BimModel
from bim2rdt.perception import Intrinsics, look_at
from bim2rdt.twin.records import ElementState
from bim2rdt.twin.snapshot import Layer, render_snapshot, vertical_fov_deg
from bim2rdt.twin.status import STATUS_COLOURS, ElementStatus

ISSUES = (ElementStatus.DEVIATING, ElementStatus.MISSING, ElementStatus.NEW, ElementStatus.NOT_BUILT)
"""The statuses a BCF topic is written for."""
SNAPSHOT = "snapshot.png"
CONTEXT_RADIUS_M = 8.0
"""BIM elements within this distance of the issue are drawn around it."""
CONTEXT_TRIANGLES = 20000
"""Most context triangles drawn per snapshot (nearest elements first)."""
HIDDEN_CLASSES = ("IfcSpace", "IfcOpeningElement")

ObjectMesh = Callable[[ElementState], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class TopicView:
    """The view a topic opens on, from a frame that saw the element: the sensor's ``T_world_camera`` (4x4,
    OpenCV axes), its vertical field of view (degrees), the ``snapshot`` (PNG: that frame's image; None: rendered
    from the camera, as for a scan) and ``seen``, where and when in words ("frame 3 (office1.pcd), time
    unknown")."""

    T_world_camera: np.ndarray
    fov_deg: float
    snapshot: bytes | None
    seen: str


def write_bcf(model: BimModel, states: Mapping[str, ElementState], path: Path, object_mesh: ObjectMesh,
              intrinsics: Intrinsics = Intrinsics(), views: Mapping[str, TopicView] | None = None) -> Path:
    """Write the BCF file atomically (mode as any new file: ``0o666`` less the umask).

    Args:
        model: The BIM the topics refer to.
        states: The twin's states by GlobalId; one topic per deviating, missing or new one.
        path: The .bcf file.
        object_mesh: The body mesh of an element (for the rendered snapshot).
        intrinsics: The camera of a rendered snapshot.
        views: GlobalId -> the frame's own view and image; an element without one gets a rendered snapshot.

    Returns:
        ``path``.
    """
    bcf = BcfXml.create_new(project_name=model.path.stem)
    context = _Context(model)
    views = views or {}
    issues = sorted((s for s in states.values() if s.status in ISSUES), key=lambda s: (s.status.value, s.global_id))
    for state in issues:
        view = views.get(state.global_id)
        topic = bcf.add_topic(topic_title(state), description(state, None if view is None else view.seen),
                              author=f"bim2rdt/{state.robot or 'robot'}", topic_type="Issue", topic_status="Open")
        topic.topic.labels = [state.status.value] + ([state.family] if state.family else [])
        topic.markup.header = bcf_model.Header(file=[bcf_model.HeaderFile(filename=model.path.name,
                                                                          is_external=True)])
        camera = view_camera(state, model) if view is None else view.T_world_camera
        fov = vertical_fov_deg(intrinsics) if view is None else view.fov_deg
        png = view.snapshot if view is not None else None
        if png is None:
            png = render_snapshot(camera, context.layers(state, object_mesh), intrinsics, topic_title(state))
        visinfo = bcf_model.VisualizationInfo(guid=str(uuid.uuid4()), components=_components(state.global_id),
                                              perspective_camera=_bcf_camera(camera, fov))
        topic.add_visinfo_handler(VisualizationInfoHandler(visinfo, snapshot=png), snapshot_filename=SNAPSHOT)
    return _save_atomic(bcf, Path(path))


def topic_title(state: ElementState) -> str:
    """A BCF topic's title: what the issue is, in a few words ("Deviating: cone moved 30 cm").

    Args:
        state: The element's state.

    Returns:
        The title.
    """
    what = state.family or state.ifc_class or "object"
    if state.status is ElementStatus.DEVIATING:
        d = state.deviation
        return f"Deviating: {what} off by {100 * d.translation:.1f} cm, tilt {d.tilt_deg:.1f}°, yaw {d.yaw_deg:.1f}°"
    if state.status is ElementStatus.MISSING:
        return f"Missing: {what} not at its BIM place"
    if state.status is ElementStatus.NOT_BUILT:
        return f"Not built: {what} seen through where the BIM has it"
    return f"New: {what} not in the BIM"


def description(state: ElementState, seen: str | None = None) -> str:
    """What the robot found, against which tolerance, with which fit, seen from where and when (``seen``: the
    frame in words, when the caller knows it better than the evidence's time and station)."""
    lines = [f"Element {state.global_id} ({state.ifc_class or 'not in the BIM'}), status: {state.status.value}."]
    if state.deviation is not None and state.tolerance is not None:
        d, t = state.deviation, state.tolerance
        lines.append(f"Deviation: {d.translation:.3f} m, tilt {d.tilt_deg:.2f}°, yaw {d.yaw_deg:.2f}° against the "
                     f"'{t.name}' tolerance of {t.translation:.3f} m / {t.rotation_deg:.1f}°.")
    if state.pose is not None:
        x, y, z = state.pose[:3, 3]
        lines.append(f"Measured at ({x:.2f}, {y:.2f}, {z:.2f}) m.")
    if state.fit is not None:
        f = state.fit
        rmse = "none (no inlier)" if f.rmse is None else f"{100 * f.rmse:.1f} cm"
        lines.append(f"Fit: rmse {rmse}, fitness {f.fitness:.2f}, {f.points} points, "
                     f"detector {f.detector or '-'} score {f.score:.2f}.")
    if seen is not None:
        lines.append(f"Seen by {state.robot} in {seen}.")
    elif state.evidence is not None:
        e = state.evidence
        when = datetime.fromtimestamp(e.time, timezone.utc).isoformat(timespec="seconds")
        lines.append(f"Seen by {state.robot} at {when} from station {e.station}, frames "
                     f"{', '.join(map(str, e.frames)) or '-'}.")
    return "\n".join(lines)


def view_camera(state: ElementState, model: BimModel) -> np.ndarray:
    """T_world_camera (OpenCV) of the view the element was seen from, else from 2.5 m off and 3.5 m up (over
    the walls), looking down at it."""
    if state.evidence is not None and state.evidence.camera is not None:
        return state.evidence.camera
    target = _target(state, model)
    return look_at(target + np.array([-1.8, -1.8, 3.5]), target)


def _target(state: ElementState, model: BimModel) -> np.ndarray:
    if state.pose is not None:
        return state.pose[:3, 3] + [0.0, 0.0, 0.3]
    return model.element(state.global_id).placement[:3, 3] + [0.0, 0.0, 0.3]


def _components(global_id: str) -> bcf_model.Components:
    return bcf_model.Components(
        selection=bcf_model.ComponentSelection(component=[bcf_model.Component(ifc_guid=global_id)]),
        visibility=bcf_model.ComponentVisibility(default_visibility=True))


def _bcf_camera(T_world_camera: np.ndarray, fov_deg: float) -> bcf_model.PerspectiveCamera:
    """BCF camera: view point, direction (the OpenCV z axis) and up (minus the OpenCV y axis), world metres."""
    position, forward, up = T_world_camera[:3, 3], T_world_camera[:3, 2], -T_world_camera[:3, 1]
    return bcf_model.PerspectiveCamera(
        camera_view_point=bcf_model.Point(x=float(position[0]), y=float(position[1]), z=float(position[2])),
        camera_direction=bcf_model.Direction(x=float(forward[0]), y=float(forward[1]), z=float(forward[2])),
        camera_up_vector=bcf_model.Direction(x=float(up[0]), y=float(up[1]), z=float(up[2])),
        field_of_view=float(fov_deg))


class _Context:
    """The BIM's meshes around an issue, for snapshots (bounding-box centres computed once)."""

    def __init__(self, model: BimModel):
        self.model = model
        self.centres = {}
        for el in model.elements:
            if el.ifc_class not in HIDDEN_CLASSES and model.has_mesh(el.global_id):
                vertices, _ = model.mesh(el.global_id)
                if len(vertices):
                    self.centres[el.global_id] = (vertices.min(axis=0) + vertices.max(axis=0)) / 2

    def layers(self, state: ElementState, object_mesh: ObjectMesh) -> list[Layer]:
        target = _target(state, self.model)
        layers, budget = [], CONTEXT_TRIANGLES
        nearest = sorted(self.centres, key=lambda gid: np.linalg.norm(self.centres[gid][:2] - target[:2]))
        for gid in nearest:
            if gid == state.global_id or np.linalg.norm(self.centres[gid][:2] - target[:2]) > CONTEXT_RADIUS_M:
                continue
            vertices, faces = self.model.mesh(gid)
            if len(faces) > budget:
                break
            budget -= len(faces)
            layers.append(Layer(vertices, faces, "0.88", 1.0, "0.7"))
        if state.in_bim and self.model.has_mesh(state.global_id):
            vertices, faces = self.model.mesh(state.global_id)
            layers.append(Layer(vertices, faces, "tab:blue", 0.3))
        if state.pose is not None:
            body, faces = object_mesh(state)
            world = np.asarray(body) @ state.pose[:3, :3].T + state.pose[:3, 3]
            layers.append(Layer(world, faces, STATUS_COLOURS[state.status], 0.95))
        return layers


def _save_atomic(bcf: BcfXml, path: Path) -> Path:
    """bcf-client saves only to a named file: it writes one in a private folder, whose bytes then go through
    :func:`~bim2rdt.atomic.write_bytes_atomic` (the mode and the atomic rename every output gets)."""
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bcf-") as folder:
        staged = Path(folder) / path.name
        bcf.save(staged)
        return write_bytes_atomic(path, staged.read_bytes())

