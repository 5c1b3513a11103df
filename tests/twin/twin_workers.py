"""A robot process for the concurrency test: opens the shared twin and records a burst of observations."""

from __future__ import annotations

from pathlib import Path

from bim2rdt.bim import load_ifc
from bim2rdt.perception.observation import Observation
from bim2rdt.sim.site import yaw_pose
from bim2rdt.twin import DigitalTwin

from twin_helpers import T0

NEW_DRUM_XY = (10.0, 8.0)


def record_burst(url: str, ifc_path: str, cache_dir: str, robot: int, count: int, barrier) -> None:
    """Robot ``robot`` records ``count`` observations (frame = step) of the site's proxies, alternately where the
    BIM puts them and 20 cm off, at interleaved times, plus the same unplanned drum as every other robot."""
    model = load_ifc(Path(ifc_path), cache_dir=Path(cache_dir))
    proxies = [el for el in model.elements if el.ifc_class == "IfcBuildingElementProxy"]
    with DigitalTwin.open(url, model, robot=f"robot-{robot}") as twin:
        barrier.wait(timeout=60)
        twin.record(Observation("Steel_Drum_55gal", None, yaw_pose(*NEW_DRUM_XY, 0.0, 0.0), 0.01, 0.9, 90,
                                station=robot, frames=(-1,)), T0)
        for step in range(count):
            el = proxies[(step + robot) % len(proxies)]
            pose = el.placement.copy()
            pose[0, 3] += 0.2 * ((step // len(proxies) + robot) % 2)
            twin.record(Observation(el.family, el.global_id, pose, 0.005, 0.9, 100, station=robot,
                                    frames=(step,)), T0 + step + 0.25 * robot)
