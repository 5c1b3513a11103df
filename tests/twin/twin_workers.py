"""Processes of the twin tests: a robot recording a burst of observations into the shared twin (concurrency), and
a monitor process that records a group of safety events and dies at once (crash)."""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

from bim2rdt.bim import load_ifc
from bim2rdt.bus import Event
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


def safety_group(zone: str | None) -> list[Event]:
    return [Event("hav.activity_started", T0, "worker-a1", "dev-1", {"zone": zone, "tool": "breaker"}),
            Event("hav.eav_predicted", T0 + 60, "worker-a1", "dev-1", {"zone": zone, "seconds_to_eav": 840.0}),
            Event("hav.gap", T0 + 61, "worker-b2", "dev-2", {})]


def record_group_and_die(url: str, ifc_path: str, cache_dir: str, zone: str) -> None:
    """Record :func:`safety_group` through the twin's sink in one call, say so, then die without closing anything
    (SIGKILL: no handler, no flush, no clean close runs)."""
    from bim2rdt.twin import TwinSink

    twin = DigitalTwin.open(url, load_ifc(Path(ifc_path), cache_dir=Path(cache_dir)))
    TwinSink(twin).emit_many(safety_group(zone))
    print("recorded", flush=True)
    sys.stdout.flush()
    os.kill(os.getpid(), signal.SIGKILL)
