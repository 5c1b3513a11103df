"""The report page's optional parts: the structure and the schedule render from the run's structure.json and
progress.json (their shapes: issue 33), a frame's heat map from deviation/ replaces the residual map, and what is
absent or unreadable leaves its section out instead of failing."""

from __future__ import annotations

import json

from bim2rdt.verify.report.page import ReportData, frame_heat, read_run_files, report_page

STRUCTURE = [{"global_id": "2MxmlzrXbUfxmClNO2BsGQ", "ifc_class": "IfcWall", "status": "as planned",
              "coverage": 0.62, "median_mm": 4.1, "p95_mm": 11.0, "offset_m": 0.004, "rotation_deg": 0.1,
              "frames": [0, 2], "reason": ""},
             {"global_id": "1TBebBOpPOig1MMN0p_zzd", "ifc_class": "IfcColumn", "status": "not built",
              "coverage": 0.0, "median_mm": None, "p95_mm": None, "offset_m": None, "rotation_deg": None,
              "frames": [1], "reason": "its place was seen empty"}]
PROGRESS = {"schedule": {"global_id": "0S", "name": "Shell"}, "date": "2026-05-01T00:00:00Z",
            "tasks": [{"global_id": "0T", "name": "Walls ground floor", "identification": "A.1",
                       "planned_start": "2026-04-01", "planned_finish": "2026-05-15", "planned_percent": 66.0,
                       "observed_percent": 50.0, "status": "behind",
                       "products": {"as planned": 1, "deviating": 0, "not built": 1, "not observed": 0},
                       "children": []}]}


def _page(**parts) -> str:
    return report_page(ReportData("t", [], [], {}, **parts))


def test_the_structure_and_schedule_sections_render_from_the_run_files(tmp_path):
    (tmp_path / "structure.json").write_text(json.dumps(STRUCTURE))
    (tmp_path / "progress.json").write_text(json.dumps(PROGRESS))
    structure, progress, heat = read_run_files(tmp_path)
    page = _page(structure=structure, progress=progress)
    assert "id='structure'" in page and "id='schedule'" in page
    assert "1TBebBOpPOig1MMN0p_zzd" in page and "not built" in page and "62.0 %" in page
    assert "Walls ground floor" in page and "66 %" in page and "50 %" in page and "Shell" in page
    assert heat == {}


def test_without_the_files_or_with_broken_ones_the_sections_are_left_out(tmp_path):
    assert read_run_files(tmp_path) == (None, None, {})
    (tmp_path / "structure.json").write_text("{not json")
    (tmp_path / "progress.json").write_text(json.dumps({"tasks": []}))
    structure, progress, _ = read_run_files(tmp_path)
    page = _page(structure=structure, progress=progress)
    assert "id='structure'" not in page and "id='schedule'" not in page


def test_a_frames_heat_map_is_the_deviation_png_whose_name_ends_in_its_index(tmp_path):
    (tmp_path / "deviation").mkdir()
    (tmp_path / "deviation" / "frame_0002.png").write_bytes(b"two")
    (tmp_path / "deviation" / "frame_0012.png").write_bytes(b"twelve")
    _, _, heat = read_run_files(tmp_path)
    assert frame_heat(heat, 2) == b"two" and frame_heat(heat, 12) == b"twelve" and frame_heat(heat, 1) is None


def test_a_new_objects_size_is_the_cluster_a_frame_sees_at_its_position():
    """A 0.6 x 0.4 x 0.9 m box standing on the floor 3 m in front of a camera looking along +x; the BIM (a wall
    behind it) is 5 m away, so the box's pixels stand 2 m in front of it."""
    import numpy as np

    from bim2rdt.perception import Intrinsics, look_at
    from bim2rdt.verify.report.capture import FrameView
    from bim2rdt.verify.report.sizes import measure

    k = Intrinsics(320, 240, 260.0, 260.0, 159.5, 119.5)
    T = look_at((0.0, 0.0, 1.0), (1.0, 0.0, 1.0))
    rays = k.pixel_rays().reshape(-1, 3) @ T[:3, :3].T  # world directions with camera z = 1
    depth = np.full(len(rays), 5.0)  # the wall at x = 5
    t = 3.0 / rays[:, 0]  # where each ray meets the box's front face, x = 3
    y, z = t * rays[:, 1], 1.0 + t * rays[:, 2]
    on_box = (np.abs(y) < 0.3) & (z > 0.0) & (z < 0.9)
    depth[on_box] = t[on_box]
    depth = depth.reshape(k.height, k.width)
    residual = np.where(depth < 5.0, depth - 5.0, 0.0)
    view = FrameView(np.zeros((k.height, k.width, 3), np.uint8), depth.astype(np.float16), k)
    size = measure(view, T, residual, np.array([3.2, 0.0, 0.0]))
    assert size is not None and abs(size[1] - 0.6) < 0.04 and abs(size[2] - 0.9) < 0.04, size
    assert measure(view, T, residual, np.array([3.2, 2.0, 0.0])) is None  # nothing stands there


def test_the_summary_counts_one_frame_in_the_singular_and_more_in_the_plural():
    from bim2rdt.verify.report.page import _summary

    one, two = [_Frame(True)], [_Frame(True), _Frame(False)]
    assert "<p>1 frame, 1 localized on the BIM." in _summary(ReportData("t", one, [], {}))
    assert "<p>2 frames, 1 localized on the BIM." in _summary(ReportData("t", two, [], {}))


class _Frame:
    """What the summary reads of a frame: whether it was localized."""

    def __init__(self, accepted: bool):
        self.accepted = accepted


def test_the_frames_table_says_where_each_frames_prior_came_from():
    from bim2rdt.verify.chain import FrameResult
    from bim2rdt.verify.report.page import _frames

    frames = [FrameResult(0, "a.pcd", None, None, prior_source="global", places=3, reason="ambiguous: 3 places fit"),
              FrameResult(1, "b.pcd", None, None, prior_source="global", places=1, resolved_at=2),
              FrameResult(2, "c.pcd", None, None, prior_source="global", places=1, resolved_at=2),
              FrameResult(3, "d.pcd", None, None, prior_source="tracked"),
              FrameResult(4, "e.pcd", None, None, prior_source="user")]
    rows = _frames(ReportData("t", frames, [], {})).split("<tr id='row-")[1:]
    assert "none: searched on the BIM (3 places fit)" in rows[0]
    assert "none: searched on the BIM, resolved at frame 2" in rows[1]
    assert "searched on the BIM</td>" in rows[2]
    assert "the last fix and odometry" in rows[3] and "yours (--prior)" in rows[4]
