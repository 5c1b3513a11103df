"""The real office frame in the perception benchmark: PCL's office1 Kinect frame (depth corrected by its truth
file's calibration) against the furniture of its as-built IFC, for two pipelines in the same run:

- **verify**: ``bim2rdt verify``'s chain from a prior 20 cm and 5 degrees off (localize on the walls, each
  planned object checked with its own body, new objects clustered);
- **geometric**: perception's geometric detector and ``perceive_frame`` on the same frame at the verify fix
  (family templates, nearest element of the family).

The as-built IFC is the truth here (authored from this scan): a furniture box is found when an observation
names its GlobalId with a pose within ``FOUND`` of its placement; an observation that names a box and lands
farther is a false claim. Clutter the IFC does not model (the truth file lists it) is neither.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

FOUND = 0.05
"""A box's observation within this of its placement (m) finds it: the twin's tolerance for furniture."""


def office_bench(sensors: Path) -> dict | None:
    """The office record, or None when ``sensors``/pcl/office1.* are absent."""
    folder = sensors / "pcl"
    if not (folder / "office1.pcd").exists() or not (folder / "office1_truth.json").exists():
        return None
    from bim2rdt.bim import load_ifc
    from bim2rdt.perception import GeometricDetector, perceive_frame
    from bim2rdt.semantics import KnowledgeBasePriors
    from bim2rdt.sources import open_source
    from bim2rdt.verify import verify_frames

    truth = json.loads((folder / "office1_truth.json").read_text())
    model = load_ifc(folder / "office1.ifc")
    frame = next(iter(open_source(folder / "office1.pcd", depth_correction=truth["depth_correction"]["g"])))
    T_true = np.array(truth["T_world_camera"])
    boxes = {b["GlobalId"]: model.element(b["GlobalId"]).placement for b in truth["furniture"]}
    start = time.process_time()
    result = verify_frames([frame], model, _off(T_true, 0.14, 0.14, 5.0))
    verify_seconds = time.process_time() - start
    fixed = result.frames[0]
    rows = [_score("verify", fixed.observations, boxes, verify_seconds)]
    if fixed.accepted:
        priors = KnowledgeBasePriors().priors(sorted({el.family for el in model.elements if el.family}))
        start = time.process_time()
        observations = perceive_frame(frame.localized(fixed.pose), model, priors, GeometricDetector(model, priors))
        rows.append(_score("geometric", observations, boxes, time.process_time() - start))
    error = None if fixed.pose is None else fixed.pose[:3, 3] - T_true[:3, 3]
    turned = None if fixed.pose is None else float(np.degrees(np.arccos(np.clip(
        (np.trace(fixed.pose[:3, :3].T @ T_true[:3, :3]) - 1) / 2, -1.0, 1.0))))
    return {"frame": "pcl/office1.pcd (Kinect v1, depth corrected)", "boxes": len(boxes), "pipelines": rows,
            "localization_error_m": None if error is None else float(np.linalg.norm(error)),
            "localization_error_deg": turned, "miscalibrated": result.miscalibrated}


def _score(name: str, observations, boxes: dict[str, np.ndarray], seconds: float) -> dict:
    found, claims, errors = set(), 0, []
    for obs in observations:
        if obs.global_id not in boxes:
            continue
        claims += 1
        shift = float(np.linalg.norm(obs.pose[:3, 3] - boxes[obs.global_id][:3, 3]))
        errors.append(shift)
        if shift <= FOUND:
            found.add(obs.global_id)
    correct = sum(1 for e in errors if e <= FOUND)
    return {"pipeline": name, "recall": len(found) / len(boxes), "precision": correct / claims if claims else 0.0,
            "claims": claims, "new": sum(1 for o in observations if o.global_id is None),
            "translation_m_median": float(np.median(errors)) if errors else None, "cpu_seconds": seconds}


def _off(T: np.ndarray, dx: float, dy: float, dyaw_deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(dyaw_deg)), np.sin(np.radians(dyaw_deg))
    out = T.copy()
    out[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ T[:3, :3]
    out[:3, 3] += (dx, dy, 0.0)
    return out
