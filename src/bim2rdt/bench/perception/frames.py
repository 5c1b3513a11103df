"""The benchmark's frames: seeded realities of the embedded site seen from the mission's stations, inside the
building, with time-of-flight artefacts and workers walking through some frames; and, per frame, how much of
each object is visible (what a detector can be asked to find)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel, load_ifc
from bim2rdt.sim.reality import objects_of_interest
from bim2rdt.sim.site import ROBOT_START_XY
from bim2rdt.mission import MissionConfig
from bim2rdt.mission.route import plan_route
from bim2rdt.perception import Frame, Intrinsics
from bim2rdt.sim.reality import Reality, simulate_reality
from bim2rdt.sim.render import RgbdFrame, cast_rays, render_rgbd
from bim2rdt.sim.scene import PlacedObject, SiteScene
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.sim.tof import TofEffects
from bim2rdt.sim.workers import worker_in_view


@dataclass(frozen=True)
class BenchFrame:
    """One frame: the rendered truth (labels), what the robot sends, the reality it shows, the visible
    fraction of every object in view ({object index: 0-1}) and whether a worker walks through it."""

    seed: int
    station: int
    rendered: RgbdFrame
    frame: Frame
    reality: Reality
    visible: dict[int, float]
    worker: bool


def site_model(folder: Path) -> BimModel:
    """The embedded site, built into ``folder`` and read with geometry."""
    return load_ifc(build_site_ifc(Path(folder) / "site.ifc"))


def bench_frames(model: BimModel, seeds: list[int], worker_fraction: float, intrinsics: Intrinsics = Intrinsics(),
                 tof: TofEffects | None = TofEffects()) -> Iterator[BenchFrame]:
    """Frames of every seed's reality from the mission's stations; a worker stands in view in about
    ``worker_fraction`` of them (seeded)."""
    targets = objects_of_interest(model)
    stations = mission_stations(model, targets)
    for seed in seeds:
        reality = simulate_reality(model, [t.global_id for t in targets], seed=seed, building=True)
        rng = np.random.default_rng([seed, 11])
        footprints = [p.mesh.bounds[:, :2].ravel() for p in reality.scene.building if p.ifc_class != "IfcSlab"]
        for station, T in enumerate(stations):
            worker = None
            if rng.random() < worker_fraction:
                worker = worker_in_view(T, rng, [o.T_world_model[:3, 3] for o in reality.scene.objects], footprints)
            scene = SiteScene(reality.scene.objects, 0.0, reality.scene.building, [worker] if worker else [])
            rendered = render_rgbd(scene, intrinsics, T, rng, tof=tof)
            yield BenchFrame(seed, station, rendered, rendered.as_frame(intrinsics), reality,
                             visible_fractions(reality.scene.objects, rendered, intrinsics), worker is not None)


def mission_stations(model: BimModel, targets) -> list[np.ndarray]:
    """The camera poses the demo's mission plans (reachable stations with a line of sight to each object, on the
    BIM's ground floor with its off-limits zones), dock first."""
    from bim2rdt.planning import OccupancyGrid

    grid = OccupancyGrid.from_bim(model).with_zones(model.zones)
    config = MissionConfig().model_copy(update={"slab_height": grid.floor_z})
    return plan_route(targets, ROBOT_START_XY, grid, config).stations


def visible_fractions(objects: list[PlacedObject], rendered: RgbdFrame, intrinsics: Intrinsics,
                      stride: int = 2) -> dict[int, float]:
    """{object index: its visible pixels / the pixels it would cover alone on an unbounded image} for the
    objects with any pixel in the frame. The unbounded image is the frame grown by half its size each way and
    ray cast every ``stride``-th pixel, so an object cut by the image edge counts as partly hidden."""
    out = {}
    rays = _canvas_rays(intrinsics, stride) @ rendered.T_world_camera[:3, :3].T
    for index in np.unique(rendered.labels[rendered.labels >= 0]):
        alone = cast_rays(SiteScene([objects[index]], ground_size=0.0), rays, rendered.T_world_camera[:3, 3])
        full = np.count_nonzero(alone.hit) * stride ** 2
        seen = np.count_nonzero(rendered.labels == index)
        out[int(index)] = min(1.0, seen / full) if full else 0.0
    return out


def _canvas_rays(intrinsics: Intrinsics, stride: int) -> np.ndarray:
    pad_u, pad_v = intrinsics.width // 2, intrinsics.height // 2
    u, v = np.meshgrid(np.arange(-pad_u, intrinsics.width + pad_u, stride),
                       np.arange(-pad_v, intrinsics.height + pad_v, stride))
    return np.stack([(u - intrinsics.cx) / intrinsics.fx, (v - intrinsics.cy) / intrinsics.fy,
                     np.ones(u.shape)], axis=-1).reshape(-1, 3)
