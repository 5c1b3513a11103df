"""Single-frame global searches with people in view, with and without free-standing things counted whole
(decision 0054): frames at each of the tour's ten stations (lap 0) turned -60 to +60 degrees in 15 degree steps,
and frames looking at each of the tour's people from eight sides at 1.5 and 3 m (inside the site), each searched
alone with the IMU's up, once with the defaults and once with ``thing_whole`` 0 (every point counted on its own).
One JSON line per frame, then the counts per outcome among the frames with a person in view (at least 2 % of the
returns) and without.

    PYTHONPATH=src python scripts/people_in_view.py /tmp/people-site
"""

from __future__ import annotations

import json
import sys
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

from bim2rdt.bim import load_ifc
from bim2rdt.localization import GlobalSearchConfig, LocalizationError, choose, find_pose
from bim2rdt.localization.planar import from_planar, to_planar, wrap
from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.sim.render import render_rgbd
from bim2rdt.sim.scene import WORKER
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.sim.tour import CAMERA_HEIGHT, PEOPLE_XY, TOUR_STATIONS, tour_scene


def poses() -> list[np.ndarray]:
    out = []
    for x, y, tx, ty in TOUR_STATIONS:
        state, tilt = to_planar(look_at((x, y, CAMERA_HEIGHT), (tx, ty, 0.8)))
        out += [from_planar(state + np.array([0.0, 0.0, 0.0, np.deg2rad(d)]), tilt) for d in range(-60, 61, 15)]
    for px, py in PEOPLE_XY:
        for side in np.deg2rad(np.arange(0, 360, 45)):
            for distance in (1.5, 3.0):
                cx, cy = px + distance * np.cos(side), py + distance * np.sin(side)
                if 0.3 < cx < 19.7 and 0.3 < cy < 13.7:
                    out.append(look_at((cx, cy, CAMERA_HEIGHT), (px, py, 0.9)))
    return out


def outcome(frame, model, up, cfg, T_true) -> list:
    started = time.process_time()
    try:
        best, reason = choose(find_pose(frame, model, up=up, config=cfg), cfg)
    except LocalizationError as error:
        best, reason = None, str(error)
    seconds = round(time.process_time() - started, 2)
    if best is None:
        return ["refused", reason[:40], seconds]
    a, b = to_planar(best.pose)[0], to_planar(T_true)[0]
    position = float(np.linalg.norm(best.pose[:3, 3] - T_true[:3, 3]))
    yaw = float(np.rad2deg(wrap(a[3] - b[3])))
    right = position < 0.05 and abs(yaw) < 1.0
    return ["right" if right else "WRONG", round(position, 2), round(yaw, 1), round(best.score, 3), seconds]


def main(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    model = load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")
    scene = tour_scene(model, seed=0).scene
    configs = {"off": GlobalSearchConfig(thing_whole=0.0), "on": GlobalSearchConfig()}
    rows = []
    for i, T in enumerate(poses()):
        rendered = render_rgbd(scene, Intrinsics(), T, np.random.default_rng(i))
        hit = np.isfinite(rendered.depth)
        share = float((rendered.labels[hit] == WORKER).mean()) if hit.any() else 0.0
        frame = replace(rendered.as_frame(Intrinsics()), T_world_camera=None)
        up = T[:3, :3].T @ np.array([0.0, 0.0, 1.0])
        row = {"i": i, "person_share": round(share, 3),
               **{name: outcome(frame, model, up, cfg, T) for name, cfg in configs.items()}}
        rows.append(row)
        print(json.dumps(row), flush=True)
    for name in configs:
        for seen, label in ((True, "person in view"), (False, "nobody in view")):
            counts = Counter(r[name][0] for r in rows if (r["person_share"] >= 0.02) == seen)
            print(name, label, dict(counts))


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/people-site"))
