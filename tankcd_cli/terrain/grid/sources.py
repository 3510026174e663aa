"""DEM inputs as windowed sources: ``grid`` (the geometry, a ``PostGrid``), ``info`` (where the
posts come from, a ``DemSourceInfo``) and ``read(r0, r1, c0, c1)``.

Four kinds serve the same interface (and ``ArrayDem``, heights in memory, for tests):

- rasters GDAL reads (GeoTIFF, COG, DTED, SRTM HGT, VRT mosaics, folders of
  tiles, ...): :mod:`tankcd_cli.io.rasters`, through rasterio;
- small ESRI ASCII grids (under ``ASC_OWN_MAX_BYTES``, and standard input):
  tankcd's own parser, read whole. Measured on this machine: a 4M-post grid
  parses in 1.3 s here against 0.37 s through GDAL, but a 39k-post one in
  0.02 s against 0.18 s, nearly all of it importing rasterio. Larger grids go
  through GDAL, which also reads them by window. Both give the same grid
  (a test).
- the heights of a grid store, to classify again with other settings;
- heightmaps (PNG, RAW) as engines write them: :mod:`tankcd_cli.io.heightmap`, placed and
  scaled as a ``HeightmapSpec`` says.

``read`` returns float64 heights, row 0 north, NaN at NODATA and beyond the
grid, so a window may reach past any edge.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os

import h5py
import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.dem_source import DemSourceInfo
from tankcd_cli.io.esri_ascii import esri_ascii_posts
from tankcd_cli.io.files import read_bytes
from tankcd_cli.io.heightmap import HeightmapSpec, open_heightmap
from tankcd_cli.io.rasters import open_raster
from tankcd_cli.io.terrain_readers import MAX_COORDINATE
from tankcd_cli.terrain.grid.store import open_grid
from tankcd_cli.terrain.store import read_attrs


class ArrayDem:
    """A DEM held in memory: heights (rows, cols) row 0 north, NaN at NODATA; ``grid`` its
    geometry (default: a local grid of 1 m posts), ``info`` its provenance."""

    def __init__(self, heights: np.ndarray, grid: PostGrid | None = None, info: DemSourceInfo | None = None):
        self.heights = heights
        self.grid = grid or PostGrid(*np.shape(heights))
        self.info = info or DemSourceInfo("<array>", "array")

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        rows, cols = self.heights.shape
        out = np.full((max(r1 - r0, 0), max(c1 - c0, 0)), np.nan)
        a, b, c, d = max(r0, 0), min(r1, rows), max(c0, 0), min(c1, cols)
        if a < b and c < d:
            out[a - r0:b - r0, c - c0:d - c0] = self.heights[a:b, c:d]
        return out

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class StoreDem:
    """The heights of a grid store, read by tile."""

    def __init__(self, path: str):
        self.surface = open_grid(path)
        self.grid = self.surface.grid
        a = read_attrs(path)
        with _h5(path) as f:
            dtype = f["grid/height"].dtype.name
        self.info = DemSourceInfo(a.get("source", path), a.get("source_format", "h5"), a.get("source_sha256", ""),
                                  a.get("source_crs_name", ""), bool(a.get("reprojected", False)), dtype,
                                  source_crs_wkt=str(a.get("source_crs", "")),
                                  source_point_scale=float(a.get("source_point_scale", 0.0)),
                                  source_point_scale_range=tuple(float(v) for v in
                                                                 a.get("source_point_scale_range", (0.0, 0.0))))

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        return self.surface.tiles.window("grid/height", r0, r1, c0, c1, np.nan, np.float64)

    def close(self) -> None:
        self.surface.tiles.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _h5(path):
    return h5py.File(path, "r")


ASC_OWN_MAX_BYTES = 4 << 20  # about 500k posts: below it our parser beats importing rasterio
SOURCE_KINDS = ("grid_store", "esri_ascii", "raster", "heightmap")  # what ``terrain.open.terrain_kind`` calls a DEM


def open_source(kind: str, path: str, fmt: str | None = None, band: int | None = None, crs: str | None = None,
                heightmap=None):
    """The DEM source (see the module doc) of ``path``, a DEM of ``kind`` (one of ``SOURCE_KINDS``,
    as ``terrain.open.terrain_kind`` names it): a grid store's heights, an ESRI grid through our
    parser when it is small and read as it is, a heightmap (PNG, RAW) as ``heightmap`` (an
    ``io.heightmap.HeightmapSpec``; ``crs`` the CRS it is in) says, any other raster through GDAL."""
    if kind not in SOURCE_KINDS:
        raise ValueError(f"not a DEM kind: {kind!r}; one of {', '.join(SOURCE_KINDS)}")
    if kind == "heightmap":
        spec = heightmap or HeightmapSpec()
        if crs and not spec.crs:
            spec = dataclasses.replace(spec, crs=crs)
        return open_heightmap(path, spec, fmt=fmt, band=band)
    if kind == "grid_store":
        if crs:
            raise InputError(path, "--crs applies to rasters; a store keeps the CRS it was classified in")
        return StoreDem(path)
    if kind == "esri_ascii" and crs is None and band in (None, 1) and (path == "-" or _size(path) < ASC_OWN_MAX_BYTES):
        return ascii_dem(path)

    return open_raster(path, band=band, crs=crs, fmt=fmt)


def _size(path: str) -> int:
    try:
        return os.path.getsize(path)
    except OSError:
        return 0  # missing: the own parser names the file in its error


def ascii_dem(path: str) -> ArrayDem:
    """An ESRI ASCII grid through tankcd's own parser."""
    name = "<stdin>" if path == "-" else path
    data = read_bytes(path, name)
    if not data.strip():
        raise InputError(name, "file is empty")
    z, valid, (x0, y0), (dx, dy) = esri_ascii_posts(data, name)
    heights = np.where(valid, z, np.nan)[::-1].copy()  # row 0 north
    rows, cols = heights.shape
    return ArrayDem(heights, PostGrid(rows, cols, x0, y0 + (rows - 1) * dy, dx, dy),
                    DemSourceInfo(name, "asc", sha256=hashlib.sha256(data).hexdigest()))


def checked_read(source, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    """A window of heights, refusing numbers no terrain has (a unit or parse error, and they
    would overflow the fits)."""
    z = source.read(r0, r1, c0, c1)
    with np.errstate(invalid="ignore"):
        huge = np.abs(z) > MAX_COORDINATE
    if huge.any():
        r, c = np.argwhere(huge)[0]
        raise InputError(source.info.source, f"height beyond {MAX_COORDINATE:.0e} m: {z[r, c]!r}",
                         where=f"row {r0 + r + 1} column {c0 + c + 1}")
    return z
