"""The grid as ROS map_server files, for Nav2: ``NAME.pgm`` + ``NAME.yaml``, and a keep-out filter mask.

The map is the unpadded occupancy (walls, columns, objects, closed doors, no floor), not the robot-grown one:
Nav2's own inflation layer grows it by the robot's footprint. Black (0) is occupied, white (254) free,
``mode: trinary``, ``negate: 0``, thresholds 0.65/0.196 (map_server's defaults). The PGM's first row is the
grid's top (largest y): ``origin`` is the world pose of the image's lower-left pixel.

The keep-out mask (``NAME_keepout``) has the same frame; black cells are keep-out zones and worker circles, for
the KeepoutFilter (costmap filter info ``type: 0``, ``base: 0.0``, ``multiplier: 1.0``; map_server
``mode: scale`` turns black into 100 = lethal). It is written only when the grid has keep-out zones.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bim2rdt.atomic import WriteError, write_bytes_atomic
from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.frame import GridFrame

OCCUPIED, FREE = 0, 254
OCCUPIED_THRESH, FREE_THRESH = 0.65, 0.196


def save_nav2(obstacles: np.ndarray, keepout: np.ndarray, frame: GridFrame, folder: Path,
              name: str) -> dict[str, Path]:
    """Write the map (``obstacles``, bool (rows, cols) on ``frame``) and, when ``keepout`` has any cell, the
    keep-out mask into ``folder``; returns {what: path}."""
    if not name or "/" in name or name.startswith("."):
        raise PlanningError(f"map name {name!r}: give a plain file stem such as 'site'")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        written = _write_map(folder, name, obstacles, frame, "trinary")
        if keepout.any():
            masks = _write_map(folder, f"{name}_keepout", keepout, frame, "scale")
            written.update({"keepout_image": masks["image"], "keepout_yaml": masks["yaml"]})
    except (OSError, WriteError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
        raise PlanningError(f"cannot write the Nav2 map into {folder}: {reason}") from None
    return written


def _write_map(folder: Path, name: str, occupied: np.ndarray, frame: GridFrame, mode: str) -> dict[str, Path]:
    pixels = np.where(occupied, OCCUPIED, FREE).astype(np.uint8)[::-1]
    header = f"P5\n# bim2rdt occupancy, {frame.resolution:g} m/cell\n{pixels.shape[1]} {pixels.shape[0]}\n255\n"
    image = write_bytes_atomic(folder / f"{name}.pgm", header.encode("ascii") + pixels.tobytes())
    x0, y0 = frame.origin_xy
    yaml = (f"image: {image.name}\nmode: {mode}\nresolution: {frame.resolution:.6f}\n"
            f"origin: [{x0:.6f}, {y0:.6f}, 0.0]\nnegate: 0\noccupied_thresh: {OCCUPIED_THRESH}\n"
            f"free_thresh: {FREE_THRESH}\n")
    return {"image": image, "yaml": write_bytes_atomic(folder / f"{name}.yaml", yaml.encode("ascii"))}
