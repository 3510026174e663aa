"""Footprint-averaged |H| on a mesh: vertex areas, the two disk averages the classes come from
(``regions.py`` derives them), and the class raster of the mesh layout.

The averages run on a regular raster over the terrain's x, y extent (an eighth of the track
length per cell, coarser for large terrains): each vertex's area and area-weighted H are
binned into its cell, summed over disks by convolution, and read back at the vertices.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.terrain.mesh.clean import twice_face_areas
from tankcd_cli.vehicle import Vehicle


@dataclass(frozen=True)
class Raster:
    """A regular raster over the terrain's x, y extent.

    origin : (2,) world x, y of the centre of cell (0, 0), m
    cell : cell size, m
    values : (ny, nx) array, row index growing northwards
    """

    origin: np.ndarray
    cell: float
    values: np.ndarray

    def cell_of(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of the cell containing each point (clipped to the raster)."""
        col = np.floor((xy[:, 0] - self.origin[0]) / self.cell + 0.5).astype(np.int64)
        row = np.floor((xy[:, 1] - self.origin[1]) / self.cell + 0.5).astype(np.int64)
        ny, nx = self.values.shape[:2]
        return np.clip(row, 0, ny - 1), np.clip(col, 0, nx - 1)


def vertex_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """A third of the area of each incident face, summed per vertex, m^2 (n,)."""
    double = twice_face_areas(vertices, faces)
    return np.bincount(faces.ravel(), weights=np.repeat(double / 6.0, 3), minlength=len(vertices))


def _disk(radius_cells: float) -> np.ndarray:
    r = int(np.floor(radius_cells))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    return (xx * xx + yy * yy <= radius_cells * radius_cells + 1e-9).astype(np.float64)


DIRECT_SUM_CELLS = 250_000
"""Rasters up to this many cells are disk-summed in numpy (the same bits as scipy's); larger ones
by ``scipy.ndimage``, four times faster at 4M cells, where its import no longer matters."""


def _direct_disk_sum(grid: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """``scipy.ndimage.convolve(grid, kernel, mode="constant")`` for a symmetric 0/1 kernel, bit
    for bit: the shifted grids added in the order it adds them (row-major over the kernel),
    one whole-grid addition per kernel cell. Without scipy, whose import is most of a small
    mesh's classify."""
    r = kernel.shape[0] // 2
    padded = np.pad(grid, r)
    rows, cols = grid.shape
    out = np.zeros_like(grid, dtype=np.float64)
    for dy, dx in zip(*np.nonzero(kernel)):
        out += padded[dy:dy + rows, dx:dx + cols]
    return out


def _disk_sum(grid: np.ndarray, radius_cells: float) -> np.ndarray:
    """Sum of ``grid`` over a disk around every cell (zero outside the grid)."""
    if radius_cells < 1:
        return grid
    kernel = _disk(radius_cells)
    if kernel.size <= 81:
        if grid.size <= DIRECT_SUM_CELLS:
            return _direct_disk_sum(grid, kernel)
        from scipy.ndimage import convolve

        return convolve(grid, kernel, mode="constant")
    from scipy.signal import fftconvolve

    return fftconvolve(grid, kernel, mode="same")


def footprint_curvature(vertices: np.ndarray, H: np.ndarray, area: np.ndarray, vehicle: Vehicle,
                        max_cells: int = 4_000_000) -> tuple[np.ndarray, Raster]:
    """Footprint-averaged |H| at each vertex and on a raster.

    vertices : (n, 3) float64, m
    H : (n,) signed mean curvature, 1/m
    area : (n,) vertex areas, m^2
    Returns (n,) averaged |H| at the vertices, 1/m, and the raster of the same
    field (NaN where no terrain lies within the footprint).

    The raster cell is an eighth of the contact length, coarsened when the
    terrain is large so that the raster stays under ``max_cells`` cells.
    """
    xy = vertices[:, :2]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    cell = max(vehicle.track_length / 8.0, float(np.sqrt(span[0] * span[1] / max_cells)))
    shape = (int(span[1] // cell) + 1, int(span[0] // cell) + 1)
    raster = Raster(lo.copy(), cell, np.zeros(shape))
    row, col = raster.cell_of(xy)
    flat_index = row * shape[1] + col
    size = shape[0] * shape[1]
    a = np.bincount(flat_index, weights=area, minlength=size).reshape(shape)
    ah = np.bincount(flat_index, weights=area * H, minlength=size).reshape(shape)

    smooth_a = _disk_sum(a, vehicle.track_length / 4.0 / cell)
    smooth_ah = _disk_sum(ah, vehicle.track_length / 4.0 / cell)
    tiny = 1e-9 * max(float(a.max()), 1e-300)  # FFT round-off is not terrain
    with np.errstate(divide="ignore", invalid="ignore"):
        h_track = np.where(smooth_a > tiny, smooth_ah / smooth_a, 0.0)
    foot_a = _disk_sum(a, vehicle.track_length / 2.0 / cell)
    foot_ah = _disk_sum(a * np.abs(h_track), vehicle.track_length / 2.0 / cell)
    with np.errstate(divide="ignore", invalid="ignore"):
        field = np.where(foot_a > tiny, foot_ah / foot_a, np.nan)
    field = np.where(np.isfinite(field), np.maximum(field, 0.0), np.nan)
    at_vertex = field[row, col]
    at_vertex = np.where(np.isfinite(at_vertex), at_vertex, np.abs(H))
    return at_vertex, Raster(raster.origin, cell, field)


def class_shares(classes: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Area share (3,) of each class."""
    total = area.sum()
    by_class = np.bincount(classes, weights=area, minlength=3)[:3]
    return by_class / total if total > 0 else by_class
