"""save_nav2: the grid as ROS map_server files (PGM + YAML) and a Nav2 keep-out mask, read back independently."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.planning import KeepOut, PlanningError
from bim2rdt.planning.grid import STRUCTURE_KINDS


def read_pgm(path):
    """A minimal independent P5 reader (no comments between the size fields expected after the first line)."""
    lines = path.read_bytes().split(b"\n", 4)
    assert lines[0] == b"P5" and lines[1].startswith(b"#") and lines[3] == b"255"
    width, height = map(int, lines[2].split())
    return np.frombuffer(lines[4], np.uint8).reshape(height, width)


def read_yaml(path):
    fields = dict(line.split(": ", 1) for line in path.read_text().splitlines())
    fields["origin"] = [float(v) for v in fields["origin"].strip("[]").split(",")]
    return fields


def test_the_map_is_the_unpadded_occupancy_with_its_top_row_first(site_grid, tmp_path):
    written = site_grid.save_nav2(tmp_path, "site")
    assert set(written) == {"image", "yaml"} and not (tmp_path / "site_keepout.pgm").exists()
    pixels = read_pgm(tmp_path / "site.pgm")
    assert pixels.shape == site_grid.frame.shape and set(np.unique(pixels)) == {0, 254}
    assert np.array_equal(pixels[::-1] == 0, site_grid.layer(STRUCTURE_KINDS + ("object",)))
    meta = read_yaml(tmp_path / "site.yaml")
    assert meta["image"] == "site.pgm" and meta["mode"] == "trinary" and meta["negate"] == "0"
    assert float(meta["resolution"]) == pytest.approx(0.05)
    assert meta["origin"] == pytest.approx([*site_grid.frame.origin_xy, 0.0])
    assert (float(meta["occupied_thresh"]), float(meta["free_thresh"])) == (0.65, 0.196)


def test_a_world_point_lands_on_its_pixel_by_the_yaml_origin(site_grid, tmp_path):
    site_grid.save_nav2(tmp_path, "site")
    pixels, meta = read_pgm(tmp_path / "site.pgm"), read_yaml(tmp_path / "site.yaml")
    column_corner = (6.1, 5.1)   # inside column C11
    col = int((column_corner[0] - meta["origin"][0]) / float(meta["resolution"]))
    row = pixels.shape[0] - 1 - int((column_corner[1] - meta["origin"][1]) / float(meta["resolution"]))
    assert pixels[row, col] == 0 and pixels[row, col - 20] == 254


def test_keepout_zones_go_into_a_mask_of_the_same_frame(site_grid, site_model, tmp_path):
    grid = site_grid.with_zones([*site_model.zones, KeepOut.circle("worker", (8.5, 8.0), 1.0, kind="person")])
    written = grid.save_nav2(tmp_path, "site")
    mask = read_pgm(written["keepout_image"])[::-1] == 0
    assert mask.shape == grid.frame.shape
    assert mask[grid.frame.cell_of((16.5, 3.0))] and mask[grid.frame.cell_of((8.5, 8.0))]
    assert not mask[grid.frame.cell_of((4.0, 3.0))]
    assert read_yaml(written["keepout_yaml"])["mode"] == "scale"


def test_the_map_reads_back_the_same_with_a_reader_that_allows_header_comments(site_grid, tmp_path):
    from nav2_maps import read_pgm as tolerant_read

    site_grid.save_nav2(tmp_path, "m")
    assert np.array_equal(tolerant_read(tmp_path / "m.pgm"), read_pgm(tmp_path / "m.pgm"))


def test_a_bad_map_name_is_refused(site_grid, tmp_path):
    with pytest.raises(PlanningError, match="plain file stem"):
        site_grid.save_nav2(tmp_path, "../escape")


@pytest.mark.parametrize("folder", ["/proc/x", "/dev/null/maps"])
def test_a_folder_that_cannot_take_the_map_is_a_one_line_error(site_grid, folder):
    with pytest.raises(PlanningError, match="cannot write the Nav2 map") as error:
        site_grid.save_nav2(folder)
    assert "\n" not in str(error.value) and folder.split("/")[1] in str(error.value)
