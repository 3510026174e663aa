"""The terrain store's grid layout (a DEM): written tile by tile, opened for windowed reads.

Layout (docs/formats.md has the whole description):

/grid/height          (rows, cols) float32|float64  post heights, m; NaN at NODATA; row 0 north.
                                                    attrs origin_x, origin_y, spacing, crs, crs_name
/curvature/mean       (rows, cols) float32          signed mean curvature H, 1/m; NaN at NODATA
/classes/grid         (rows, cols) uint8            0 flat, 1 general, 2 uneven; 255 at NODATA
/overview/classes     (oh, ow) uint8                worst class per block of ``overview_step`` posts (maps)
/overview/curvature   (oh, ow) float32              mean footprint-averaged |H| per block

Every full raster is chunked in ``TILE`` x ``TILE`` tiles, uncompressed, each
with a Fletcher-32 checksum, so a reader fetches only the tiles it touches,
each in one read, and a damaged tile is an error (exit 3), never wrong ground. Heights are kept
as float32 when every source value is exactly a float32 (16-bit integer DEMs,
float32 GeoTIFFs), else float64: 9 or 13 bytes a post in all. The footprint-averaged
|H| the classes come from is kept only in the overview (maps): the classes are what
later commands read.
"""

from __future__ import annotations

import math

import h5py
import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.h5 import read_errors
from tankcd_cli.terrain.grid.surface import GridSurface
from tankcd_cli.terrain.grid.tiles import DEFAULT_CACHE_BYTES, TileReader
from tankcd_cli.terrain.store import FORMAT, FORMAT_VERSION, WHAT, open_store, read_attrs

TILE = 256
OVERVIEW_MAX = 1024  # posts of the overview's longer side at most


class GridStoreWriter:
    """Create a grid store at ``path`` and fill it with classified tiles (``write``)."""

    def __init__(self, path: str, grid: PostGrid, height_dtype: str = "float64"):
        rows, cols = grid.rows, grid.cols
        self.rows, self.cols = rows, cols
        self.h5 = h5py.File(path, "w")
        self.h5.attrs["format"] = FORMAT
        self.h5.attrs["format_version"] = FORMAT_VERSION
        self.h5.attrs["layout"] = "grid"
        chunk = (min(TILE, rows), min(TILE, cols))
        # every tile carries a Fletcher-32 checksum: a damaged store is an error, never wrong ground
        tiles = {"chunks": chunk, "fletcher32": True}
        h = self.h5.create_dataset("grid/height", (rows, cols), dtype=np.dtype(height_dtype), fillvalue=np.nan,
                                   **tiles)
        h.attrs["origin_x"] = float(grid.origin_x)
        h.attrs["origin_y"] = float(grid.origin_y)
        h.attrs["spacing"] = np.asarray(grid.spacing, dtype=float)
        h.attrs["crs"] = grid.crs_wkt
        h.attrs["crs_name"] = grid.crs_name
        self.height = h
        self.mean = self.h5.create_dataset("curvature/mean", (rows, cols), dtype=np.float32, fillvalue=np.nan,
                                           **tiles)
        self.classes = self.h5.create_dataset("classes/grid", (rows, cols), dtype=np.uint8, fillvalue=255,
                                              **tiles)
        self.step = max(1, math.ceil(max(rows, cols) / OVERVIEW_MAX))
        oh, ow = math.ceil(rows / self.step), math.ceil(cols / self.step)
        self._ov_class = np.full((oh, ow), -1, dtype=np.int16)
        self._ov_sum = np.zeros((oh, ow))
        self._ov_count = np.zeros((oh, ow))
        self.by_class = np.zeros(3)
        self.valid = 0
        self.zmin, self.zmax = np.inf, -np.inf

    def write(self, t) -> None:
        """Store one :class:`~tankcd_cli.terrain.grid.tiled_classify.TileResult`."""
        r0, c0 = t.r0, t.c0
        r1, c1 = r0 + t.height.shape[0], c0 + t.height.shape[1]
        self.height[r0:r1, c0:c1] = t.height.astype(self.height.dtype)
        self.mean[r0:r1, c0:c1] = t.mean.astype(np.float32)
        self.classes[r0:r1, c0:c1] = t.classes
        self.by_class += t.area_by_class
        self.valid += t.valid
        if t.valid:
            self.zmin = min(self.zmin, float(np.nanmin(t.height)))
            self.zmax = max(self.zmax, float(np.nanmax(t.height)))
        self._overview(t, r0, c0)

    def _overview(self, t, r0: int, c0: int) -> None:
        """Fold a tile into the overview: blocks aligned to multiples of ``step`` in the grid
        (a block cut by a tile edge is completed by the neighbouring tile)."""
        s = self.step
        h, w = t.height.shape
        br0, bc0 = r0 // s, c0 // s
        nbr, nbc = (r0 + h - 1) // s - br0 + 1, (c0 + w - 1) // s - bc0 + 1
        pr, pc = r0 - br0 * s, c0 - bc0 * s
        valid = t.classes != 255

        def blocks(values, fill):
            pad = np.full((nbr * s, nbc * s), fill, dtype=values.dtype)
            pad[pr:pr + h, pc:pc + w] = values
            return pad.reshape(nbr, s, nbc, s)

        sl = np.s_[br0:br0 + nbr, bc0:bc0 + nbc]
        cls = blocks(np.where(valid, t.classes, -1).astype(np.int16), -1).max(axis=(1, 3))
        self._ov_class[sl] = np.maximum(self._ov_class[sl], cls)
        self._ov_sum[sl] += blocks(np.where(valid, np.nan_to_num(t.footprint), 0.0), 0.0).sum(axis=(1, 3))
        self._ov_count[sl] += blocks(valid.astype(float), 0.0).sum(axis=(1, 3))

    def finish(self, attrs: dict) -> None:
        ov = self.h5.create_dataset("overview/classes", data=np.where(self._ov_class < 0, 255, self._ov_class)
                                    .astype(np.uint8))
        ov.attrs["step"] = self.step
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(self._ov_count > 0, self._ov_sum / self._ov_count, np.nan)
        self.h5.create_dataset("overview/curvature", data=mean.astype(np.float32)).attrs["step"] = self.step
        for key, value in attrs.items():
            self.h5.attrs[key] = value
        self.h5.close()

    def abort(self) -> None:
        try:
            self.h5.close()
        except Exception:  # closing a half-written file while unwinding: nothing more to save
            pass


def open_grid(path: str, cache_bytes: int | None = None) -> GridSurface:
    """The GridSurface of a grid store (reads no raster)."""
    what = WHAT
    h5 = open_store(path)
    with h5, read_errors(path, what):
        h = h5["grid/height"]
        rows, cols = h.shape
        for name in ("classes/grid", "curvature/mean"):
            if h5[name].shape != (rows, cols):
                raise InputError(path, f"damaged {what}: {name} is {h5[name].shape}, the grid {rows} x {cols}")
        spacing = np.asarray(h.attrs["spacing"], dtype=float)
        origin = (float(h.attrs["origin_x"]), float(h.attrs["origin_y"]))
        crs, crs_name = (_text(h.attrs.get(key, "")) for key in ("crs", "crs_name"))
        chunk = h.chunks[0] if h.chunks else TILE
        if h.chunks is None or h5["classes/grid"].chunks != h.chunks:
            raise InputError(path, f"damaged {what}: grid rasters are not chunked in tiles")
    if spacing.shape != (2,) or not (np.isfinite(spacing).all() and (spacing > 0).all()) \
            or not np.isfinite(origin).all() or rows < 2 or cols < 2:
        raise InputError(path, f"damaged {what}: bad grid geometry")
    tiles = TileReader(path=path, tile=chunk, max_bytes=cache_bytes or DEFAULT_CACHE_BYTES)
    grid = PostGrid(int(rows), int(cols), origin[0], origin[1], float(spacing[0]), float(spacing[1]), crs, crs_name)
    return GridSurface(tiles, grid)


def read_overview(path: str) -> dict:
    """The overview rasters (``classes``, ``curvature``, one value per block of ``step`` x ``step``
    posts), the grid's geometry (``grid``, a PostGrid) and the root attributes (for maps)."""
    attrs = read_attrs(path)
    with read_errors(path, WHAT), h5py.File(path, "r") as h5:
        h = h5["grid/height"]
        dx, dy = (float(v) for v in h.attrs["spacing"])
        grid = PostGrid(h.shape[0], h.shape[1], float(h.attrs["origin_x"]), float(h.attrs["origin_y"]), dx, dy,
                        _text(h.attrs.get("crs", "")), _text(h.attrs.get("crs_name", "")))
        return {"classes": h5["overview/classes"][()], "curvature": h5["overview/curvature"][()],
                "step": int(h5["overview/classes"].attrs["step"]), "grid": grid, "attrs": attrs}


def _text(value) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)
