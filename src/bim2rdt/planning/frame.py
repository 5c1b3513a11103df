"""The grid's frame: which world rectangle each cell covers.

Rows run along world y, columns along world x; cell (row, col) covers
``[x0 + col*res, x0 + (col+1)*res) x [y0 + row*res, y0 + (row+1)*res)`` and its centre is half a cell in. Cell
coordinates ``(u, v)`` are the same lengths measured in cells from the origin, so cell ``(i, j)`` spans
``u in [j, j+1)``, ``v in [i, i+1)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_CELLS = 60_000_000
"""Refuse grids larger than this (a 5 cm grid of 390 m x 390 m): a typo in the resolution, not a building."""


@dataclass(frozen=True)
class GridFrame:
    """``origin_xy``: world (x, y) of the grid's lower-left corner, metres; ``resolution``: cell edge, metres;
    ``shape``: (rows, cols)."""

    origin_xy: tuple[float, float]
    resolution: float
    shape: tuple[int, int]

    @classmethod
    def covering(cls, low_xy: np.ndarray, high_xy: np.ndarray, resolution: float, margin: float) -> GridFrame:
        """The smallest grid of ``resolution`` covering the box [low, high] grown by ``margin`` metres."""
        low = np.asarray(low_xy, float) - margin
        cols, rows = np.ceil((np.asarray(high_xy, float) + margin - low) / resolution).astype(int) + 1
        return cls((float(low[0]), float(low[1])), float(resolution), (int(rows), int(cols)))

    def to_cells(self, xy: np.ndarray) -> np.ndarray:
        """World (..., 2) metres -> cell coordinates (u, v), floats."""
        return (np.asarray(xy, float) - self.origin_xy) / self.resolution

    def to_world(self, uv: np.ndarray) -> np.ndarray:
        """Cell coordinates (..., 2) -> world metres."""
        return np.asarray(uv, float) * self.resolution + self.origin_xy

    def cell_of(self, xy) -> tuple[int, int]:
        """(row, col) of the cell holding world point ``xy`` (may lie outside the grid; see ``contains``). A point
        far outside (up to 1e308 m away, where the cell index overflows) gets a cell just outside the grid."""
        with np.errstate(over="ignore", invalid="ignore"):
            u, v = self.to_cells(xy)
        row = np.clip(np.floor(v), -1, self.shape[0])
        col = np.clip(np.floor(u), -1, self.shape[1])
        return int(row), int(col)

    def contains(self, cell: tuple[int, int]) -> bool:
        return 0 <= cell[0] < self.shape[0] and 0 <= cell[1] < self.shape[1]

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """World (N, 2) centres of cells (rows[k], cols[k])."""
        x = self.origin_xy[0] + (np.asarray(cols, float) + 0.5) * self.resolution
        y = self.origin_xy[1] + (np.asarray(rows, float) + 0.5) * self.resolution
        return np.stack([x, y], axis=-1)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) metres: what matplotlib's ``imshow(..., origin="lower")`` wants."""
        x0, y0 = self.origin_xy
        return x0, x0 + self.shape[1] * self.resolution, y0, y0 + self.shape[0] * self.resolution
