"""The README's and the guide's Python examples cannot rot: every ```python block of README.md and
docs/guide/*.md runs, in a temporary folder, against the embedded site.

A block may say what it takes as given in an HTML comment just before it (mkdocs does not show it):

- ``<!-- example: given ... -->``: the names the prose takes as given (the site's model, a frame a camera
  sent, an odometry prior) come from :data:`GIVEN`, built here from the embedded site and the simulator;
  ``site.ifc`` (what ``bim2rdt site site.ifc`` writes) is in the folder for every block;
- ``<!-- example: skip REASON -->``: the block needs what is not in the repo (a user's recordings, a robot);
  it is compiled and its ``bim2rdt`` imports are checked, then the test skips with the reason.
"""

from __future__ import annotations

import ast
import importlib
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]
CONE = "Traffic_Cone_Orange_70cm"
BLOCK = re.compile(r"(?:<!-- example: (?P<note>.*?) -->\n)?```python\n(?P<code>.*?)```", re.DOTALL)


def python_blocks(markdown: str) -> list[tuple[str, str]]:
    """(note, code) of every ```python block, the note empty when the block has none."""
    return [(match["note"] or "", match["code"]) for match in BLOCK.finditer(markdown)]


def examples() -> list[tuple[str, str, str]]:
    return [(f"{page.relative_to(ROOT)}:{index}", note, code) for page in PAGES
            for index, (note, code) in enumerate(python_blocks(page.read_text(encoding="utf-8")))]


def check_imports(code: str) -> None:
    """Every ``from bim2rdt... import name`` of the code names something that exists."""
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("bim2rdt"):
            module = importlib.import_module(node.module)
            missing = [alias.name for alias in node.names if not hasattr(module, alias.name)]
            assert not missing, f"{node.module} has no {', '.join(missing)}"


@pytest.fixture(scope="session")
def site_ifc(tmp_path_factory) -> Path:
    from bim2rdt.sim.site import build_site_ifc

    return build_site_ifc(tmp_path_factory.mktemp("example-site") / "site.ifc")


@pytest.fixture(scope="session")
def site_model(site_ifc):
    from bim2rdt.bim import load_ifc

    return load_ifc(site_ifc)


def rendered_view(model) -> dict:
    """rgb, depth and T_world_camera of a camera 2.6 m from one of the site's cones, the cone placed near where
    the BIM puts it and turned 15 degrees (the simulator's frame, as a robot would send it)."""
    from bim2rdt.perception import Intrinsics, look_at
    from bim2rdt.sim.building import building_scene
    from bim2rdt.sim.meshes import mesh_for_family
    from bim2rdt.sim.render import render_rgbd
    from bim2rdt.sim.scene import PlacedObject, ground_pose
    from bim2rdt.sim.site import SURFACE_COLOURS

    cone = [el for el in model.elements if el.family == CONE][1]
    placed = PlacedObject(CONE, mesh_for_family(CONE), ground_pose(*cone.position[:2], np.deg2rad(15.0)),
                          colour=SURFACE_COLOURS[CONE])
    camera = look_at((4.2, 4.6, 1.1), (4.2, 2.0, 0.35))
    frame = render_rgbd(building_scene(model, [placed]), Intrinsics(), camera, np.random.default_rng(0))
    return {"rgb": frame.colour, "depth": frame.depth.astype(np.float32), "T_world_camera": camera,
            "frame": frame.as_frame(Intrinsics())}


def odometry_prior(T_world_camera: np.ndarray) -> np.ndarray:
    """The camera's pose 10 cm and 2 degrees (about world z) off, as legged odometry would have it."""
    yaw = np.deg2rad(2.0)
    T_off = np.eye(4)
    T_off[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    T_off[:3, 3] = [0.08, -0.06, 0.0]
    return T_off @ T_world_camera


def given(note: str, model) -> dict:
    """The names a block's note says it takes as given."""
    if "rgb, depth, T_world_camera" in note:
        view = rendered_view(model)
        return {"model": model, **{name: view[name] for name in ("rgb", "depth", "T_world_camera")}}
    if "odometry prior" in note:
        view = rendered_view(model)
        return {"model": model, "frame": view["frame"], "prior_T_world_camera": odometry_prior(view["T_world_camera"])}
    return {}


def test_the_guide_has_python_examples_that_run_and_some_that_skip_with_a_reason():
    notes = [note for _, note, _ in examples()]
    assert len(notes) >= 6
    assert sum(note.startswith("given") for note in notes) >= 4
    assert all(note.startswith(("given", "skip ")) for note in notes if note)


def test_a_block_reads_its_note_and_code():
    markdown = "text\n<!-- example: skip needs a robot -->\n```python\nx = 1\n```\n\n```python\ny = 2\n```\n"
    assert python_blocks(markdown) == [("skip needs a robot", "x = 1\n"), ("", "y = 2\n")]


def test_an_import_of_a_name_the_package_lacks_fails_the_check():
    with pytest.raises(AssertionError, match="no plan_everything"):
        check_imports("from bim2rdt.planning import plan_path, plan_everything\n")


@pytest.mark.parametrize("where, note, code", examples(), ids=[where for where, _, _ in examples()])
def test_the_example_runs(where, note, code, site_ifc, site_model, tmp_path, monkeypatch):
    check_imports(code)
    if note.startswith("skip "):
        compile(code, where, "exec")
        pytest.skip(f"{where}: {note.removeprefix('skip ')}")
    monkeypatch.chdir(tmp_path)
    shutil.copy(site_ifc, tmp_path / "site.ifc")
    (tmp_path / "out").mkdir()
    namespace = given(note, site_model)
    exec(compile(code, where, "exec"), namespace)  # noqa: S102 - the repo's own documentation
