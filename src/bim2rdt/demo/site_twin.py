"""The demo's twin: a fresh SQLite twin under the demo's output folder, every mission observation recorded into
it (with the camera of the station it was seen best from: :func:`bim2rdt.mission.record_mission`), the HAV monitor's events into its history, and the
exports written beside the report: ``site_twin.ifc`` (through ``export_ifc``), ``site_issues.bcf`` and
``twin.json``.

The demo simulates a new day, so its twin starts empty; a site's own twin (``Settings.twin.url``, shared by
several robots in PostgreSQL) is never touched by the demo.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel, load_ifc
from bim2rdt.mission.record import STATION_SECONDS, record_mission  # noqa: F401 (the demo's names for them)
from bim2rdt.semantics import UprightPrior
from bim2rdt.sim.meshes import UnknownFamilyError, mesh_for_family
from bim2rdt.twin import DigitalTwin, ElementState, ElementStatus, TwinConfig, TwinError

TWIN_DB = "twin.db"
ROBOT = "robot-1"


@dataclass
class TwinFiles:
    """What the twin exported: the IFC (None when the model cannot be written back, with ``ifc_note`` saying
    why), the BCF issues and the JSON state."""

    ifc: Path | None
    bcf: Path
    json: Path
    ifc_note: str | None = None


def open_day_twin(out_dir: Path, model: BimModel, priors: Mapping[str, UprightPrior],
                  config: TwinConfig = TwinConfig()) -> DigitalTwin:
    """A new, empty twin at ``out_dir/twin.db`` judged by ``config``'s presets, with each family's symmetry
    from its prior and the simulator's family meshes for objects the BIM lacks."""
    for stale in (TWIN_DB, f"{TWIN_DB}-wal", f"{TWIN_DB}-shm"):
        (out_dir / stale).unlink(missing_ok=True)
    return DigitalTwin.open(f"sqlite:///{out_dir / TWIN_DB}", model, tolerances=config.tolerance_policy(),
                            symmetry={family: prior.symmetry for family, prior in priors.items()},
                            min_fitness=config.min_fitness, robot=ROBOT, family_mesh=_family_mesh)


def export_day_twin(twin: DigitalTwin, out_dir: Path) -> TwinFiles:
    """``site_twin.ifc`` (IFC4 models), ``site_issues.bcf`` and ``twin.json`` into ``out_dir``."""
    bcf, json_path = twin.export_bcf(out_dir / "site_issues.bcf"), twin.export_json(out_dir / "twin.json")
    try:
        return TwinFiles(twin.export_ifc(out_dir / "site_twin.ifc"), bcf, json_path)
    except TwinError as error:
        return TwinFiles(None, bcf, json_path, str(error))


def ifc_records(path: Path | None) -> list[tuple[str, str]]:
    """(IFC class, GlobalId) of every IfcEvent and IfcTask in the exported twin."""
    if path is None:
        return []
    written = load_ifc(path, geometry=False)
    return [("IfcEvent", e.global_id) for e in written.events] + [("IfcTask", t.global_id) for t in written.tasks]


@dataclass(frozen=True)
class Outline:
    """An observed object on a plan: ``name``, its plan outline where the robot found it (N,2 world metres; the
    BIM's outline for a missing one), its status value, and the BIM's outline (None for an object the BIM
    lacks): the fields of the plan map's ``MapObject``."""

    name: str
    outline_xy: np.ndarray
    status: str
    planned_xy: np.ndarray | None


def map_outlines(twin: DigitalTwin, states: Mapping[str, ElementState]) -> list[Outline]:
    """Plan outlines (convex hulls of the footprint) of every observed object of ``states``."""
    outlines = []
    for state in states.values():
        if state.status is ElementStatus.NOT_OBSERVED:
            continue
        body, _ = twin.object_mesh(state)
        planned = None
        if state.in_bim:
            placement = twin.model.element(state.global_id).placement
            planned = _hull_xy(np.asarray(body) @ placement[:3, :3].T + placement[:3, 3])
        pose = state.pose
        found = _hull_xy(np.asarray(body) @ pose[:3, :3].T + pose[:3, 3]) if pose is not None else planned
        if found is not None:
            outlines.append(Outline(state.family or state.global_id, found, state.status.value, planned))
    return outlines


def _hull_xy(points_world: np.ndarray) -> np.ndarray:
    from scipy.spatial import ConvexHull

    unique = np.unique(np.round(points_world[:, :2], 4), axis=0)
    return unique[ConvexHull(unique).vertices] if len(unique) >= 3 else unique


def _family_mesh(family: str) -> tuple[np.ndarray, np.ndarray] | None:
    try:
        mesh = mesh_for_family(family)
    except UnknownFamilyError:
        return None  # the twin stands a box in
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)
