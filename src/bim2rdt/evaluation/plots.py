"""Before/after figures of a registration scenario, drawn from the camera's point of view (matplotlib Agg).

Panels: the initial guesses, plain ICP, SG-ICP. Grey dots are the scene points the methods saw; coloured dots
are each object's model samples at the method's pose; faint black dots the model at the true pose.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.evaluation.stats import ScenarioResult
from bim2rdt.sim.scenarios import Scenario

_COLOURS = ("tab:orange", "tab:blue", "tab:green", "tab:purple")


def plot_before_after(scenario: Scenario, result: ScenarioResult, path: Path, trial: int = 0,
                      methods: tuple[str, ...] = ("ICP", "SG-ICP")) -> Path:
    """Save the figure of one trial as PNG at ``path`` (atomically) and return the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    objects = scenario.trials[trial]
    panels = [("initial guess", [o.T_init for o in objects])]
    panels += [(name, result.poses[name][trial]) for name in methods if name in result.poses]
    figure, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 4.2), squeeze=False)
    project = _projector(scenario)
    for axis, (title, poses) in zip(axes[0], panels):
        _draw(axis, scenario, objects, poses, project)
        axis.set_title(title)
    figure.suptitle(f"{scenario.spec.name}: {scenario.spec.description} (trial {trial})")
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    plt.close(figure)
    return write_bytes_atomic(path, buffer.getvalue())


def _projector(scenario: Scenario, intrinsics: Intrinsics = Intrinsics()):
    T_camera_world = np.linalg.inv(look_at(scenario.spec.eye, scenario.spec.target))

    def project(points_world: np.ndarray) -> np.ndarray:
        cam = points_world @ T_camera_world[:3, :3].T + T_camera_world[:3, 3]
        return np.c_[intrinsics.fx * cam[:, 0] / cam[:, 2] + intrinsics.cx,
                     intrinsics.fy * cam[:, 1] / cam[:, 2] + intrinsics.cy]

    return project


def _draw(axis, scenario: Scenario, objects, poses, project) -> None:
    for index, (obj, pose) in enumerate(zip(objects, poses)):
        model = scenario.models[obj.family][0][::4]
        scene_uv = project(obj.scene_pts_world)
        axis.scatter(scene_uv[:, 0], scene_uv[:, 1], s=2, c="0.6")
        truth_uv = project(model @ obj.T_world_model[:3, :3].T + obj.T_world_model[:3, 3])
        axis.scatter(truth_uv[:, 0], truth_uv[:, 1], s=1, c="k", alpha=0.15)
        posed_uv = project(model @ pose[:3, :3].T + pose[:3, 3])
        axis.scatter(posed_uv[:, 0], posed_uv[:, 1], s=2, c=_COLOURS[index % len(_COLOURS)],
                     label=obj.family)
    axis.set_xlim(0, 640)
    axis.set_ylim(480, 0)
    axis.set_aspect("equal")
    axis.legend(loc="lower right", fontsize=6, markerscale=4)
