"""Deviation maps: each return coloured by its signed distance to the nearest permanent face
(:mod:`~bim2rdt.structure.distances`), as a PNG per frame (the heat map over the camera's image; a scan's as an
equirectangular panorama from the scanner) and one coloured ``.ply`` per run (binary, float xyz, uchar
red/green/blue and a float ``deviation`` in metres: CloudCompare opens it with the colours and the distance as a
scalar field).

Red is in front of the face (towards the sensor), blue behind it, white on it; the scale runs over
``colour_limit``; grey returns are farther than ``far`` from every face (furniture, people, clutter).
"""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bim2rdt.atomic import write_bytes_atomic  # noqa: E402
from bim2rdt.bim import BimModel  # noqa: E402
from bim2rdt.perception import Frame  # noqa: E402
from bim2rdt.structure.config import StructureConfig  # noqa: E402
from bim2rdt.structure.distances import FaceSamples  # noqa: E402

CMAP = "RdBu_r"
GREY = np.array([150, 150, 150], dtype=np.uint8)


def deviation_colours(distances: np.ndarray, limit: float) -> np.ndarray:
    """(N, 3) uint8 colours of signed distances (m): the diverging map over +-``limit``, grey where NaN.

    Args:
        distances: (N,) signed distances, metres (NaN: not the structure's).
        limit: The scale's end, metres.

    Returns:
        The colours.
    """
    rgba = plt.get_cmap(CMAP)((np.nan_to_num(distances) / limit + 1) / 2)
    colours = (rgba[:, :3] * 255).astype(np.uint8)
    colours[~np.isfinite(distances)] = GREY
    return colours


def write_ply(path: Path, points: np.ndarray, colours: np.ndarray, distances: np.ndarray) -> Path:
    """A binary little-endian PLY of coloured points with their deviation, written atomically.

    Args:
        path: The .ply file.
        points: (N, 3) world metres.
        colours: (N, 3) uint8.
        distances: (N,) signed distances, metres (NaN where not the structure's).

    Returns:
        The written path.
    """
    vertex = np.empty(len(points), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "u1"), ("green", "u1"),
                                          ("blue", "u1"), ("deviation", "<f4")])
    vertex["x"], vertex["y"], vertex["z"] = points.T
    vertex["red"], vertex["green"], vertex["blue"] = colours.T
    vertex["deviation"] = distances
    header = ("ply\nformat binary_little_endian 1.0\ncomment bim2rdt deviation: signed distance to the nearest "
              f"permanent face, m\nelement vertex {len(points)}\nproperty float x\nproperty float y\n"
              "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
              "property float deviation\nend_header\n")
    return write_bytes_atomic(Path(path), header.encode("ascii") + vertex.tobytes())


def heat_png(path: Path, image: np.ndarray, title: str, limit: float) -> Path:
    """The heat map image (H, W, 3 uint8) as a PNG with a colour bar (mm), written atomically.

    Args:
        path: The .png file.
        image: The coloured image.
        title: Its title.
        limit: The scale's end, metres.

    Returns:
        The written path.
    """
    height, width = image.shape[:2]
    fig, ax = plt.subplots(figsize=(width / 100 + 1.6, height / 100 + 0.5), dpi=100)
    ax.imshow(image)
    ax.set_axis_off()
    ax.set_title(title, fontsize=9)
    scale = plt.cm.ScalarMappable(cmap=CMAP, norm=plt.Normalize(-1000 * limit, 1000 * limit))
    fig.colorbar(scale, ax=ax, fraction=0.04, label="to the nearest permanent face, mm (+ in front)")
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", bbox_inches="tight")
    plt.close(fig)
    return write_bytes_atomic(Path(path), buffer.getvalue())


class DeviationMaps:
    """A run's deviation maps: :meth:`add` writes a frame's PNG into ``out_dir`` and keeps its coloured points;
    :meth:`finish` writes ``deviation.ply`` beside it.

    Args:
        model: The BIM, loaded with geometry.
        folder: Where the PNGs go (``deviation/``); ``deviation.ply`` goes in its parent.
        config: Colour scale, the structure's reach, sample spacing, the .ply's size.
    """

    def __init__(self, model: BimModel, folder: Path, config: StructureConfig) -> None:
        self.folder, self.config = Path(folder), config
        self.samples = FaceSamples.of(model, config.sample_spacing)
        self._points: list[np.ndarray] = []
        self._distances: list[np.ndarray] = []
        self.pngs: list[Path] = []

    def add(self, index: int, frame: object, points_sensor: np.ndarray, pose: np.ndarray) -> Path:
        """One frame's map: its PNG written, its points kept for the .ply.

        Args:
            index: The frame's index (the PNG is ``frame_{index:03d}.png``).
            frame: The :class:`Frame` (its image and pixels), or a scan (anything else: a panorama).
            points_sensor: (N, 3) its returns in the sensor frame, metres; a Frame's in the order of its valid
                depth pixels (row-major).
            pose: (4, 4) T_world_sensor.

        Returns:
            The PNG's path.
        """
        points_sensor = np.asarray(points_sensor, dtype=np.float64)
        finite = np.all(np.isfinite(points_sensor), axis=1)
        world = points_sensor @ pose[:3, :3].T + pose[:3, 3]
        distances = np.full(len(world), np.nan)
        distances[finite] = self.samples.signed(world[finite], pose[:3, 3], self.config.far)
        colours = deviation_colours(distances, self.config.colour_limit)
        image = (_over_image(frame, colours) if isinstance(frame, Frame)
                 else _panorama(points_sensor[finite], colours[finite]))
        keep = np.flatnonzero(finite)[:: max(1, int(finite.sum()) // 200_000)]
        self._points.append(world[keep].astype(np.float32))
        self._distances.append(distances[keep].astype(np.float32))
        name = f"frame_{index:03d}.png"
        path = heat_png(self.folder / name, image, f"frame {index}: signed distance to the nearest permanent face",
                        self.config.colour_limit)
        self.pngs.append(path)
        return path

    def finish(self, path: Path) -> Path | None:
        """Write the run's coloured cloud (thinned evenly to ``ply_points``).

        Args:
            path: The .ply file.

        Returns:
            The written path, or None when no frame was added.
        """
        if not self._points:
            return None
        points, distances = np.concatenate(self._points), np.concatenate(self._distances)
        step = max(1, -(-len(points) // self.config.ply_points))
        points, distances = points[::step], distances[::step]
        return write_ply(path, points, deviation_colours(distances, self.config.colour_limit), distances)


def _over_image(frame: Frame, colours: np.ndarray) -> np.ndarray:
    """The frame's image in grey with each valid depth pixel's colour blended over it."""
    grey = frame.rgb.astype(np.float32).mean(axis=2, keepdims=True).repeat(3, axis=2) * 0.6
    v, u = np.nonzero(frame.valid_depth)
    grey[v, u] = 0.25 * grey[v, u] + 0.75 * colours.astype(np.float32)
    return grey.astype(np.uint8)


def _panorama(points_sensor: np.ndarray, colours: np.ndarray, width: int = 1024) -> np.ndarray:
    """A scan's returns seen from the scanner (equirectangular, azimuth across, elevation up; nearest in front)."""
    height = width // 2
    image = np.full((height, width, 3), 255, dtype=np.uint8)
    if len(points_sensor) == 0:
        return image
    r = np.linalg.norm(points_sensor, axis=1)
    azimuth = np.arctan2(points_sensor[:, 1], points_sensor[:, 0])
    elevation = np.arcsin(np.clip(points_sensor[:, 2] / np.maximum(r, 1e-9), -1, 1))
    u = np.clip(((np.pi - azimuth) / (2 * np.pi) * width).astype(int), 0, width - 1)
    v = np.clip(((np.pi / 2 - elevation) / np.pi * height).astype(int), 0, height - 1)
    order = np.argsort(-r)  # far first: the nearest return of a pixel is drawn last
    image[v[order], u[order]] = colours[order]
    return image
