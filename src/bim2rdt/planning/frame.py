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
        """The smallest grid covering a box grown by a margin.

        Args:
            low_xy: World (x, y) of the box's lower-left corner, metres.
            high_xy: World (x, y) of the box's upper-right corner, metres.
            resolution: Cell edge, metres.
            margin: How far the grid reaches beyond the box on every side, metres.

        Returns:
            The grid frame.
        """
        low = np.asarray(low_xy, float) - margin
        cols, rows = np.ceil((np.asarray(high_xy, float) + margin - low) / resolution).astype(int) + 1
        return cls((float(low[0]), float(low[1])), float(resolution), (int(rows), int(cols)))

    def to_cells(self, xy: np.ndarray) -> np.ndarray:
        """Convert world points to cell coordinates.

        Args:
            xy: (..., 2) world (x, y), metres.

        Returns:
            (..., 2) cell coordinates (u along columns, v along rows), floats.
        """
        return (np.asarray(xy, float) - self.origin_xy) / self.resolution

    def to_world(self, uv: np.ndarray) -> np.ndarray:
        """Convert cell coordinates to world points.

        Args:
            uv: (..., 2) cell coordinates (u along columns, v along rows).

        Returns:
            (..., 2) world (x, y), metres.
        """
        return np.asarray(uv, float) * self.resolution + self.origin_xy

    def cell_of(self, xy: np.ndarray | tuple[float, float]) -> tuple[int, int]:
        """The cell holding a world point. A point far outside (up to 1e308 m away, where the cell index
        overflows) gets a cell just outside the grid.

        Args:
            xy: World (x, y), metres.

        Returns:
            (row, col); it may lie outside the grid (see ``contains``).
        """
        with np.errstate(over="ignore", invalid="ignore"):
            u, v = self.to_cells(xy)
        row = np.clip(np.floor(v), -1, self.shape[0])
        col = np.clip(np.floor(u), -1, self.shape[1])
        return int(row), int(col)

    def contains(self, cell: tuple[int, int]) -> bool:
        """Whether a cell lies inside the grid.

        Args:
            cell: (row, col).

        Returns:
            True when both indices are within the grid's shape.
        """
        return 0 <= cell[0] < self.shape[0] and 0 <= cell[1] < self.shape[1]

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """The world centres of cells.

        Args:
            rows: (N,) row indices.
            cols: (N,) column indices.

        Returns:
            (N,2) world (x, y) of the cells (rows[k], cols[k]), metres.
        """
        x = self.origin_xy[0] + (np.asarray(cols, float) + 0.5) * self.resolution
        y = self.origin_xy[1] + (np.asarray(rows, float) + 0.5) * self.resolution
        return np.stack([x, y], axis=-1)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) metres: what matplotlib's ``imshow(..., origin="lower")`` wants."""
        x0, y0 = self.origin_xy
        return x0, x0 + self.shape[1] * self.resolution, y0, y0 + self.shape[0] * self.resolution
