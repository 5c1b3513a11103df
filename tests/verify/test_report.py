"""verify's report and BCF on a rendered RGB-D frame of the embedded site with one cone moved 30 cm: the page is
self-contained, opens in headless Chromium with every image rendered and a row per observed element; the cone's
BCF topic opens from the frame's sensor (its position, direction and field of view) with that frame's image, and a
frame without a timestamp says "time unknown" with its source and index."""

from __future__ import annotations

import io
import json
import os
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from bim2rdt.perception import Frame, Intrinsics, look_at
from bim2rdt.twin.snapshot import vertical_fov_deg
from bim2rdt.verify import record_twin, verify_frames, write_outputs
from bim2rdt.verify.report import FrameCapture

CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--no-first-run"]
CONE = "3DmeSfPWXGbvPhJacQdCcd"  # the middle of the three cones at y = 2
CAMERA = Intrinsics(320, 200, 260.0, 260.0, 159.5, 99.5)  # not the 640 x 480 of a rendered snapshot
HIDDEN = ("IfcSpace", "IfcOpeningElement")


def _render(model, T_world_camera: np.ndarray, moved: dict[str, np.ndarray]) -> Frame:
    """A frame of the model's bodies (``moved``: GlobalId -> world offset), built here by ray casting, not by
    verify: depth along z, grey structure and orange objects, no timestamp."""
    meshes, colours = [], []
    for el in model.elements:
        if el.ifc_class in HIDDEN or not model.has_mesh(el.global_id):
            continue
        vertices, faces = model.mesh(el.global_id)
        meshes.append(trimesh.Trimesh(vertices + moved.get(el.global_id, 0.0), faces, process=False))
        colours.append((230, 110, 20) if el.family and el.ifc_class == "IfcBuildingElementProxy" else (150, 150, 150))
    scene = trimesh.util.concatenate(meshes)
    owner = np.repeat(np.arange(len(meshes)), [len(m.faces) for m in meshes])
    rays = CAMERA.pixel_rays().reshape(-1, 3)
    directions = (rays / np.linalg.norm(rays, axis=1, keepdims=True)) @ T_world_camera[:3, :3].T
    hits, ray_ids, faces = scene.ray.intersects_location(np.broadcast_to(T_world_camera[:3, 3], directions.shape),
                                                        directions, multiple_hits=False)
    depth = np.zeros(len(rays), np.float32)
    depth[ray_ids] = ((hits - T_world_camera[:3, 3]) @ T_world_camera[:3, 2]).astype(np.float32)
    rgb = np.zeros((len(rays), 3), np.uint8)
    rgb[ray_ids] = np.asarray(colours, np.uint8)[owner[faces]]
    shape = (CAMERA.height, CAMERA.width)
    return Frame(rgb.reshape(*shape, 3), depth.reshape(shape), CAMERA, source="rendered")


@pytest.fixture(scope="module")
def run(site_model, tmp_path_factory):
    """verify of the frame from a prior 8 cm off, its twin and every output."""
    out = tmp_path_factory.mktemp("report")
    T_true = look_at((6.7, 4.5, 1.3), (4.2, 1.5, 0.3))  # across a corner: the fix is full (a view of one wall
    frame = _render(site_model, T_true, {CONE: np.array([0.3, 0.0, 0.0])})  # leaves its objects unverified)
    prior = T_true.copy()
    prior[:3, 3] += (0.0, 0.08, 0.0)
    capture = FrameCapture([frame])
    result = verify_frames(capture, site_model, prior)
    assert result.frames[0].accepted, result.frames[0].reason
    with record_twin(result, site_model, out) as twin:
        write_outputs(result, twin, out, capture.views)
    return out, result, capture


def test_the_moved_cone_is_deviating_and_its_bcf_topic_opens_from_the_frames_sensor(run):
    out, result, capture = run
    states = {e["global_id"]: e for e in json.loads((out / "twin.json").read_text())["elements"]}
    assert states[CONE]["status"] == "deviating"
    pose, view = result.frames[0].pose, capture.views[0]
    with zipfile.ZipFile(out / "issues.bcf") as bcf:
        topic = next(name.split("/")[0] for name in bcf.namelist()
                     if name.endswith(".bcfv") and CONE in bcf.read(name).decode())
        visinfo = next(bcf.read(n).decode() for n in bcf.namelist() if n.startswith(topic) and n.endswith(".bcfv"))
        markup = bcf.read(f"{topic}/markup.bcf").decode()
        snapshot = Image.open(io.BytesIO(bcf.read(f"{topic}/snapshot.png")))
    point = [float(v) for v in re.search(r"<CameraViewPoint>\s*<X>(.*?)</X>\s*<Y>(.*?)</Y>\s*<Z>(.*?)</Z>",
                                         visinfo, re.S).groups()]
    direction = [float(v) for v in re.search(r"<CameraDirection>\s*<X>(.*?)</X>\s*<Y>(.*?)</Y>\s*<Z>(.*?)</Z>",
                                             visinfo, re.S).groups()]
    fov = float(re.search(r"<FieldOfView>(.*?)</FieldOfView>", visinfo).group(1))
    assert np.allclose(point, pose[:3, 3], atol=1e-6) and np.allclose(direction, pose[:3, 2], atol=1e-6)
    assert fov == pytest.approx(vertical_fov_deg(view.intrinsics))
    assert snapshot.size == (2 * view.intrinsics.width, 2 * view.intrinsics.height)  # the frame, not a rendering
    assert "frame 0 (rendered), time unknown" in markup and "1970" not in markup


def test_the_report_is_one_page_with_no_outside_resource(run):
    out, _, _ = run
    page = (out / "report.html").read_text()
    assert not re.search(r"""src=['"](?!data:)""", page)  # every image embedded
    assert "<link" not in page and "<script" not in page


@pytest.fixture
def chromium() -> str:
    if not Path(CHROMIUM).exists():
        message = f"{CHROMIUM} is absent (apt-get install chromium; .ci/run does)"
        pytest.fail(message) if os.environ.get("CI") else pytest.skip(message)
    return CHROMIUM


def test_the_report_renders_its_images_and_a_row_per_observed_element_in_chromium(run, chromium):
    from playwright.sync_api import sync_playwright

    out, result, _ = run
    observed = sorted(e["global_id"] for e in json.loads((out / "twin.json").read_text())["elements"]
                      if e["status"] != "not observed")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=FLAGS)
        page = browser.new_page()
        page.goto((out / "report.html").as_uri())
        widths = page.eval_on_selector_all("img", "images => images.map(i => i.complete ? i.naturalWidth : 0)")
        rows = page.eval_on_selector_all("tr.element", "rows => rows.map(r => r.id)")
        cone = page.eval_on_selector_all(f"#el-{CONE} td", "cells => cells.map(c => c.innerText)")
        alts = page.eval_on_selector_all("img", "images => images.map(i => i.alt)")
        browser.close()
    assert len(widths) >= 4 and all(w > 0 for w in widths), widths  # plan, frame, heat map, BCF snapshot
    assert {"plan", "frame 0", "heat map 0"} <= set(alts), alts
    assert sorted(r.removeprefix("el-") for r in rows) == observed
    assert cone[3] == "deviating" and cone[4].startswith("off by"), cone
    assert abs(float(cone[5]) - 30.0) < 5.0 and abs(float(cone[6])) < 5.0, cone  # dx, dy in cm
