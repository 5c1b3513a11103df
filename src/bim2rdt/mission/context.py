"""What a mission works on and with, in one value: the BIM's targets, the stations, the families' priors and the
settings (:class:`MissionContext`), shared by the mission's loop (:func:`~bim2rdt.mission.run.run_mission`) and
the robot loop around it (:func:`~bim2rdt.mission.robot.run_robot_mission`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import trimesh

from bim2rdt.bim import BimModel
from bim2rdt.localization import LocalizationConfig
from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.explained import KnownSurface, building_surfaces
from bim2rdt.mission.records import Target
from bim2rdt.mission.verdict import DEFAULT_MIN_FITNESS
from bim2rdt.registration import IcpConfig
from bim2rdt.semantics import UprightPrior
from bim2rdt.twin import TolerancePolicy


@dataclass(frozen=True)
class MissionContext:
    """What a mission works on and with: the BIM ``targets`` and the ``stations`` (T_world_camera) to see them
    from, the ``model`` (None: a mission without a building), the families' upright ``priors``,
    ``new_object_mesh(family)`` for objects the BIM lacks, and the settings (``config``, ``icp``, the twin's
    ``tolerances`` and ``min_fitness``, the robot's ``localization``). ``building``: the BIM's permanent surfaces
    (default: :func:`~bim2rdt.mission.explained.building_surfaces` of ``model``, none without one); ``tick`` is
    called after each station."""

    targets: Sequence[Target]
    stations: Sequence[np.ndarray]
    model: BimModel | None
    priors: dict[str, UprightPrior]
    new_object_mesh: Callable[[str], trimesh.Trimesh]
    config: MissionConfig = MissionConfig()
    icp: IcpConfig = IcpConfig()
    tolerances: TolerancePolicy | None = None
    min_fitness: float = DEFAULT_MIN_FITNESS
    localization: LocalizationConfig | None = None
    building: Sequence[KnownSurface] | None = None
    tick: Callable[[], None] = lambda: None

    def with_building(self) -> MissionContext:
        """This context with the building's surfaces computed (once, for several runs).

        Returns:
            This context when it already has them, else a copy with ``building`` set (empty without a model).
        """
        if self.building is not None:
            return self
        return replace(self, building=building_surfaces(self.model) if self.model is not None else ())
