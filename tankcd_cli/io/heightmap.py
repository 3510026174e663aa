"""Heightmaps as game engines and terrain tools write them: PNG (8- or 16-bit grey) and RAW
(``.raw``, ``.r16``: little-endian unsigned 16-bit; ``.r8``: 8-bit; ``.r32``: little-endian
float32), unitless values in a grid whose world size and height range are kept elsewhere. A
:class:`HeightmapSpec` says what the file does not: the post spacing (required), how values
become heights, where the grid lies and in which CRS.

The grid (the store's convention, docs/formats.md): row 0 is the file's first row, the image's
top, and is the north; column 0 is the west. ``origin`` is the world x, y of post [0, 0], the
north-west post (the image's top-left pixel); by default the south-west post is at (0, 0), so
the heightmap covers x 0 .. (cols - 1) spacing, y 0 .. (rows - 1) spacing, as engines place a
terrain. Posts are square, ``spacing`` m apart (at least ``MIN_SPACING``, a micrometre, and
the grid's extent within ``terrain_readers.MAX_COORDINATE``; posts finer than 1/100 of the
vehicle's track length warn when classified: ``terrain/grid/resolution.py``).

Heights: height = z_offset + z_scale * value (defaults 0 and 1: the values are metres; the
scale is positive, as a height range's LOW < HIGH: a negative one would turn the terrain
upside down, a slip refused as bad input). The
height-range form, ``z_range = (LOW, HIGH)``, maps the full scale of an integer heightmap
(0 .. 65535 for 16 bits, 0 .. 255 for 8) onto LOW .. HIGH: z_scale = (HIGH - LOW) / full scale,
z_offset = LOW, as Unity's "terrain height" and World Machine's or Gaea's export range say it
(Unreal's landscape with Z scale S %: z_scale = S / 12800, z_offset = -2.56 S).

Reading, window by window: PNG through GDAL (rasterio; its block cache is held to 64 MB), RAW
through a numpy memory map of just the rows a window needs, mapped for that read and released
after it: memory does not grow with the heightmap. A heightmap has no NODATA: an alpha channel
and a PNG's transparent colour are ignored (said under -v), as is a world file (.pgw: give
``origin`` and ``spacing``). A float32 RAW's non-finite values are missing posts.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
from dataclasses import dataclass

import numpy as np

from tankcd_cli.errors import InputError, warn
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.dem_source import DemSourceInfo
from tankcd_cli.io.rasters import (
    SCALE_TOLERANCE,
    crs_label,
    crs_name,
    file_sha256,
    gdal_env,
    gdal_message,
    is_gdal_error,
    metric_crs,
    point_scale,
    quiet_warnings,
)
from tankcd_cli.io.terrain_readers import MAX_COORDINATE

PNG_SUFFIXES = ("png",)
RAW_SUFFIXES = ("raw", "r16", "r32", "r8")
HEIGHTMAP_SUFFIXES = PNG_SUFFIXES + RAW_SUFFIXES
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
# RAW types by suffix; a .raw is 16-bit unless its size only fits 8-bit posts
RAW_TYPES = {"raw": "<u2", "r16": "<u2", "r8": "u1", "r32": "<f4"}
MIN_SPACING = 1e-6  # m: finer posts are a unit slip (and their squares underflow the curvature's differences)
SPACING_NEEDED = ("a heightmap holds no post spacing: give --spacing M (tankcd classify) or spacing = M in the "
                  "scene's [terrain] table")


@dataclass(frozen=True)
class HeightmapSpec:
    """What a heightmap's file does not say (None: not given; the defaults are in the module doc).

    spacing : post spacing, m (required to read a heightmap)
    z_scale, z_offset : height = z_offset + z_scale * value, m
    z_range : (LOW, HIGH): the full scale of an integer heightmap mapped onto LOW .. HIGH m
        (instead of z_scale and z_offset)
    origin : world (x, y) of the north-west post, m
    crs : the CRS those coordinates are in (a projected CRS in metres; recorded, not warped to)
    size : (cols, rows) of a RAW (default: square)
    band : the channel of a colour PNG that holds the heights (from 1)
    """

    spacing: float | None = None
    z_scale: float | None = None
    z_offset: float | None = None
    z_range: tuple | None = None
    origin: tuple | None = None
    crs: str | None = None
    size: tuple | None = None
    band: int | None = None

    # the command line's spelling of each field
    LABELS = {"spacing": "--spacing", "z_scale": "--z-scale", "z_offset": "--z-offset", "z_range": "--z-range",
              "origin": "--origin", "crs": "--crs", "size": "--size", "band": "--band"}
    # fields that also apply to other DEMs
    SHARED = ("crs", "band")

    def given(self) -> list[str]:
        """The fields given, by name."""
        return [k for k in self.LABELS if getattr(self, k) is not None]

    def cli_args(self) -> list[str]:
        """The ``tankcd classify`` options that say the same (for a child process)."""
        args: list[str] = []
        for key in self.given():
            value = getattr(self, key)
            if key == "size":
                args += ["--size", f"{value[0]}x{value[1]}"]
            elif isinstance(value, tuple):
                args += [self.LABELS[key], *(repr(float(v)) for v in value)]
            elif key == "crs":
                args += ["--crs", value]
            elif key == "band":
                args += ["--band", str(int(value))]
            else:
                args += [self.LABELS[key], repr(float(value))]
        return args


def parse_size(text: str) -> tuple[int, int]:
    """``COLSxROWS`` (e.g. 1025x513) as (cols, rows); ValueError otherwise."""
    parts = text.lower().replace(" ", "").split("x")
    if len(parts) != 2 or not all(p.isdigit() for p in parts):
        raise ValueError(f"{text!r} is not COLSxROWS (e.g. 1025x1025)")
    cols, rows = int(parts[0]), int(parts[1])
    if cols < 2 or rows < 2:
        raise ValueError(f"{text!r}: a heightmap needs at least 2 x 2 posts")
    return cols, rows


def heightmap_format(path: str, fmt: str | None) -> str:
    """"png" or a RAW suffix, from ``fmt`` or the file's suffix (a PNG by its signature too)."""
    f = (fmt or "").lower().lstrip(".")
    if f:
        return f
    suffix = os.path.splitext(path)[1].lower().lstrip(".")
    if suffix in HEIGHTMAP_SUFFIXES:
        return suffix
    return "png"  # terrain_kind calls a file a heightmap by its suffix or the PNG signature


def is_png(path: str) -> bool:
    """Whether the file starts with the PNG signature."""
    try:
        with open(path, "rb") as fh:
            return fh.read(8) == PNG_MAGIC
    except OSError:
        return False


def is_heightmap(path: str) -> bool:
    """Whether ``path`` names a heightmap: by its suffix, or a PNG by its signature (what
    ``terrain.open.terrain_kind`` and a scene's checks both ask)."""
    if path == "-":
        return False
    if os.path.splitext(path)[1].lower().lstrip(".") in HEIGHTMAP_SUFFIXES:
        return True
    return os.path.isfile(path) and is_png(path)


def _checked(spec: HeightmapSpec | None, name: str) -> HeightmapSpec:
    """The spec, its numbers checked (bad input, exit 3, naming the option)."""
    spec = spec or HeightmapSpec()
    if spec.spacing is None:
        raise InputError(name, SPACING_NEEDED)
    if not (_finite(spec.spacing) and spec.spacing > 0):
        raise InputError(name, f"--spacing must be a positive number of metres, got {spec.spacing!r}")
    if spec.spacing < MIN_SPACING:
        raise InputError(name, f"--spacing {spec.spacing!r} m is finer than {MIN_SPACING:g} m (a micrometre): no "
                               "terrain is posted so finely; give the post spacing in metres")
    for key in ("z_scale", "z_offset"):
        value = getattr(spec, key)
        if value is not None and not _finite(value):
            raise InputError(name, f"{spec.LABELS[key]} must be a finite number, got {value!r}")
    if spec.z_scale is not None and spec.z_scale == 0:
        raise InputError(name, "--z-scale 0 makes every height the same: give the metres one value step is")
    if spec.z_scale is not None and spec.z_scale < 0:
        # as a reversed --z-range is: a terrain turned upside down is a slip, not a use
        raise InputError(name, f"--z-scale must be positive, got {spec.z_scale!r}: a negative scale turns the "
                               "terrain upside down (give --z-offset for the height of value 0)")
    if spec.z_range is not None:
        if spec.z_scale is not None or spec.z_offset is not None:
            raise InputError(name, "--z-range says the scale and the offset: give it or --z-scale/--z-offset, not both")
        low, high = spec.z_range
        if not (_finite(low) and _finite(high) and low < high):
            raise InputError(name, f"--z-range needs LOW < HIGH, finite, got {low!r} {high!r}")
    if spec.origin is not None and not all(_finite(v) for v in spec.origin):
        raise InputError(name, f"--origin must be two finite numbers X Y, got {spec.origin!r}")
    return spec


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _scale_offset(spec: HeightmapSpec, name: str, dtype: np.dtype, bits: int) -> tuple[float, float]:
    if spec.z_range is not None:
        if dtype.kind == "f":
            raise InputError(name, "--z-range maps an integer heightmap's full scale; this one holds float32 "
                                   "heights: give --z-scale and --z-offset, if any")
        full = float(2 ** bits - 1)
        low, high = (float(v) for v in spec.z_range)
        return (high - low) / full, low
    scale = 1.0 if spec.z_scale is None else float(spec.z_scale)
    return scale, (0.0 if spec.z_offset is None else float(spec.z_offset))


def _grid(spec: HeightmapSpec, rows: int, cols: int, name: str) -> PostGrid:
    h = float(spec.spacing)
    extent = (max(rows, cols) - 1) * h
    if extent > MAX_COORDINATE:
        raise InputError(name, f"--spacing {spec.spacing!r} m over {max(rows, cols):,} posts spans {extent:.3g} m, "
                               f"beyond {MAX_COORDINATE:.0e} m: give the post spacing in metres")
    if spec.origin is None:
        x0, y0 = 0.0, (rows - 1) * h  # the south-west post at (0, 0)
    else:
        x0, y0 = float(spec.origin[0]), float(spec.origin[1])
    crs_wkt, crs_words = "", "local grid (no CRS)"
    if spec.crs:
        crs = metric_crs(spec.crs, name)
        crs_wkt, crs_words = crs.to_wkt(), crs_name(crs)
    return PostGrid(rows, cols, x0, y0, h, h, crs_wkt, crs_words)


def _crs_facts(spec: HeightmapSpec, grid: PostGrid, name: str) -> dict:
    """The DemSourceInfo fields of a heightmap's --crs (its WKT and point scale); a SetupWarning
    when that CRS's metres stray more than 1 % from ground metres over the grid (a heightmap is
    placed, not reprojected: its spacing and heights would be taken as the CRS's metres)."""
    if not grid.crs_wkt:
        return {}
    from rasterio.crs import CRS

    crs = CRS.from_wkt(grid.crs_wkt)
    south = grid.origin_y - (grid.rows - 1) * grid.dy
    east = grid.origin_x + (grid.cols - 1) * grid.dx
    scale = point_scale(crs, (grid.origin_x, south, east, grid.origin_y))
    if scale is None:
        return {"source_crs_wkt": grid.crs_wkt}
    if scale.off_by > SCALE_TOLERANCE:
        warn(name, f"{crs_label(crs)} metres are {1 / scale.centre:.2f} ground metres here (point scale "
                   f"{scale.centre:.2f} at the centre{scale.range_text()}): a heightmap is placed, not reprojected, "
                   "so its slopes and distances are off by that much; give --origin and --spacing in a CRS whose "
                   "metres are ground metres (the UTM zone of the place)")
    return {"source_crs_wkt": grid.crs_wkt, "source_point_scale": scale.centre,
            "source_point_scale_range": (scale.low, scale.high)}


def _reading(spec: HeightmapSpec, kind: str, dtype: np.dtype, bits: int, band: int, rows: int, cols: int,
             scale: float, offset: float, grid: PostGrid) -> str:
    """How the file's values became posts, as JSON text (the store's ``heightmap`` attribute)."""
    return json.dumps({"format": kind, "values": np.dtype(dtype).name, "bits": bits, "band": band,
                       "size": [cols, rows], "spacing": grid.dx, "z_scale": scale, "z_offset": offset,
                       "z_range": list(spec.z_range) if spec.z_range is not None else None,
                       "origin": [grid.origin_x, grid.origin_y], "origin_given": spec.origin is not None,
                       "crs": spec.crs or ""}, sort_keys=True)


class _Heightmap:
    """A heightmap served as a DEM source: ``grid``, ``info``, ``read(r0, r1, c0, c1)`` (float64
    heights, row 0 north, NaN beyond the grid), a context manager."""

    grid: PostGrid
    info: DemSourceInfo
    scale: float
    offset: float

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        r0, r1, c0, c1 = int(r0), int(r1), int(c0), int(c1)
        if r1 < r0 or c1 < c0:
            raise ValueError(f"inverted window rows {r0}-{r1} cols {c0}-{c1}")
        out = np.full((r1 - r0, c1 - c0), np.nan)
        a0, a1 = max(r0, 0), min(r1, self.grid.rows)
        b0, b1 = max(c0, 0), min(c1, self.grid.cols)
        if a0 < a1 and b0 < b1:
            values = self._values(a0, a1, b0, b1).astype(np.float64)
            heights = self.offset + self.scale * values
            heights[~np.isfinite(heights)] = np.nan
            out[a0 - r0:a1 - r0, b0 - c0:b1 - c0] = heights
        return out

    def _values(self, a0: int, a1: int, b0: int, b1: int) -> np.ndarray:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _height_dtype(dtype: np.dtype, scale: float, offset: float) -> str:
    # the values themselves are exact in float32 (8- and 16-bit integers, float32); scaled, float64
    return "float32" if scale == 1.0 and offset == 0.0 else "float64"


class RawHeightmap(_Heightmap):
    """A RAW heightmap: rows of little-endian values, the first row north."""

    def __init__(self, path: str, kind: str, spec: HeightmapSpec | None):
        name = "<stdin>" if path == "-" else path
        spec = _checked(spec, name)
        self._data = None
        if path == "-":
            data = sys.stdin.buffer.read()
            nbytes, digest = len(data), hashlib.sha256(data).hexdigest()
            self._data = data
        else:
            if os.path.isdir(path):
                raise InputError(name, "is a directory, not a file")
            if not os.path.exists(path):
                raise InputError(name, "no such file")

            nbytes, digest = os.path.getsize(path), file_sha256(path, name)
        if nbytes == 0:
            raise InputError(name, "file is empty")
        dtype = np.dtype(RAW_TYPES[kind])
        cols, rows, dtype = _raw_shape(name, kind, nbytes, dtype, spec.size)
        self.path, self.dtype, self.rows, self.cols = path, dtype, rows, cols
        bits = dtype.itemsize * 8
        self.scale, self.offset = _scale_offset(spec, name, dtype, bits)
        self.grid = _grid(spec, rows, cols, name)
        word = {"u1": "8-bit", "<u2": "16-bit unsigned", "<f4": "32-bit float"}[dtype.str.replace("|", "")]
        notes = (f"RAW heightmap: {word} little-endian values, {cols} columns x {rows} rows"
                 + ("" if spec.size else " (square)") + "; row 0 (the file's first) north",)
        reading = _reading(spec, kind, dtype, bits, 1, rows, cols, self.scale, self.offset, self.grid)
        self.info = DemSourceInfo(name, "RAW", sha256=digest,
                                  height_dtype=_height_dtype(dtype, self.scale, self.offset), dtype=dtype.name,
                                  heightmap=reading, notes=notes, **_crs_facts(spec, self.grid, name))

    def _values(self, a0, a1, b0, b1):
        row_bytes = self.cols * self.dtype.itemsize
        if self._data is not None:
            block = np.frombuffer(self._data, dtype=self.dtype, count=(a1 - a0) * self.cols, offset=a0 * row_bytes)
            return block.reshape(a1 - a0, self.cols)[:, b0:b1]
        try:
            # mapped for this read only: the pages are released with the map, so memory stays flat
            mapped = np.memmap(self.path, dtype=self.dtype, mode="r", offset=a0 * row_bytes, shape=(a1 - a0, self.cols))
            values = np.array(mapped[:, b0:b1])
            del mapped
        except OSError as exc:
            raise InputError(self.info.source, f"rows {a0}-{a1}: cannot read: {exc.strerror or exc}") from None
        return values


def _raw_shape(name: str, kind: str, nbytes: int, dtype: np.dtype, size) -> tuple[int, int, np.dtype]:
    """(cols, rows, dtype) of a RAW of ``nbytes``: by ``size``, else square; a .raw that fits only
    8-bit posts is 8-bit."""
    types = [dtype] + ([np.dtype("u1")] if kind == "raw" else [])
    words = {1: "8-bit", 2: "16-bit", 4: "32-bit"}
    if size is not None:
        cols, rows = size
        for t in types:
            if cols * rows * t.itemsize == nbytes:
                return cols, rows, t
        need = " or ".join(f"{cols * rows * t.itemsize:,} bytes of {words[t.itemsize]} posts" for t in types)
        raise InputError(name, f"is {nbytes:,} bytes: --size {cols}x{rows} needs {need}")
    for t in types:
        if nbytes % t.itemsize == 0:
            n = math.isqrt(nbytes // t.itemsize)
            if n * n * t.itemsize == nbytes and n >= 2:
                return n, n, t
    kinds = " or ".join(words[t.itemsize] for t in types)
    raise InputError(name, f"is {nbytes:,} bytes: not a square of {kinds} posts; give --size COLSxROWS")


class PngHeightmap(_Heightmap):
    """A PNG heightmap through GDAL: 8- or 16-bit grey (an alpha channel ignored), or one channel
    of a colour image chosen with ``band``."""

    def __init__(self, path: str, spec: HeightmapSpec | None, band: int | None = None):
        name = "<stdin>" if path == "-" else path
        spec = _checked(spec, name)
        if spec.size is not None:
            raise InputError(name, "--size applies to RAW heightmaps; a PNG says its own size")
        self._keep, self._ds = [], None
        if path == "-":
            from rasterio.io import MemoryFile

            data = sys.stdin.buffer.read()
            if not data:
                raise InputError(name, "file is empty")
            digest = hashlib.sha256(data).hexdigest()
            with gdal_env():
                memfile = MemoryFile(data, ext=".png")
            self._keep.append(memfile)
            gdal_path = memfile.name
        else:
            if os.path.isdir(path):
                raise InputError(name, "is a directory, not a file")
            if not os.path.exists(path):
                raise InputError(name, "no such file")
            digest, gdal_path = file_sha256(path, name), path
        import rasterio

        with gdal_env(), quiet_warnings():
            try:
                ds = rasterio.open(gdal_path, driver="PNG")
            except Exception as exc:
                if not is_gdal_error(exc):
                    raise
                self.close()
                raise InputError(name, f"not a PNG GDAL can read: {gdal_message(exc)}") from None
        self._ds = ds
        try:
            self._setup(ds, name, digest, spec, band)
        except BaseException:
            self.close()
            raise

    def _setup(self, ds, name, digest, spec, band):
        from rasterio.enums import ColorInterp

        interp = list(ds.colorinterp)
        notes = []
        colours = [i + 1 for i, c in enumerate(interp) if c in (ColorInterp.red, ColorInterp.green, ColorInterp.blue)]
        if interp and interp[0] == ColorInterp.palette:
            raise InputError(name, "is a palette (indexed-colour) PNG: its values are colour indices, not heights; "
                                   "save it as 8- or 16-bit greyscale")
        if band is None:
            if colours:
                raise InputError(name, f"has colour channels ({', '.join(c.name for c in interp)}): give --band N "
                                       f"to use one (1..{ds.count}), or save the heightmap as greyscale")
            band = 1
        if not 1 <= band <= ds.count:
            raise InputError(name, f"--band {band} is out of range: the PNG has {ds.count} channel"
                                   f"{'s' if ds.count > 1 else ''} (1..{ds.count})")
        if ds.width < 2 or ds.height < 2:
            raise InputError(name, f"a {ds.height} x {ds.width} image is too small: needs at least 2 x 2 posts")
        dtype = np.dtype(ds.dtypes[band - 1])
        if dtype.kind != "u" or dtype.itemsize > 2:
            raise InputError(name, f"holds {dtype.name} values: a PNG heightmap is 8- or 16-bit")
        bits = int(ds.tags(band, ns="IMAGE_STRUCTURE").get("NBITS", dtype.itemsize * 8))
        if ColorInterp.alpha in interp and interp[band - 1] != ColorInterp.alpha:
            notes.append("alpha channel ignored (a heightmap has no missing posts)")
        if colours:
            notes.append(f"channel {band} ({interp[band - 1].name}) of a colour PNG read as heights")
        if any(v is not None for v in ds.nodatavals):
            notes.append("the PNG's transparent colour ignored (a heightmap has no missing posts)")
        if not ds.transform.is_identity:
            notes.append("the PNG's georeferencing (a world file) ignored: --origin and --spacing place a heightmap")
        if ds.tags(ns="IMAGE_STRUCTURE").get("INTERLACED", "NO").upper() == "YES":
            notes.append("interlaced PNG: GDAL decodes it whole, so memory grows with it (save it non-interlaced)")
        self.band, self.rows, self.cols = band, ds.height, ds.width
        self.scale, self.offset = _scale_offset(spec, name, dtype, bits)
        self.grid = _grid(spec, self.rows, self.cols, name)
        notes.insert(0, f"PNG heightmap: {bits}-bit values, {self.cols} columns x {self.rows} rows; row 0 (the top) "
                        "north")
        self.info = DemSourceInfo(name, "PNG", sha256=digest,
                                  height_dtype=_height_dtype(dtype, self.scale, self.offset), dtype=dtype.name,
                                  band=band, bands=ds.count,
                                  block=tuple(int(v) for v in ds.block_shapes[band - 1]),
                                  heightmap=_reading(spec, "png", dtype, bits, band, self.rows, self.cols, self.scale,
                                                     self.offset, self.grid),
                                  notes=tuple(notes), **_crs_facts(spec, self.grid, name))
        self._probe(name)

    def _probe(self, name):
        """Read the last row: a cut-short file fails here, at open."""
        self._values(self.rows - 1, self.rows, 0, 1, name)

    def _values(self, a0, a1, b0, b1, name=None):
        from rasterio.windows import Window

        if self._ds is None:
            raise ValueError("read from a closed heightmap")
        with gdal_env():
            try:
                return self._ds.read(self.band, window=Window(b0, a0, b1 - b0, a1 - a0), masked=False)
            except Exception as exc:
                if not is_gdal_error(exc):
                    raise
                raise InputError(name or self.info.source,
                                 f"damaged PNG (rows {a0}-{a1}): {gdal_message(exc)}") from None

    def close(self) -> None:
        things = [t for t in [getattr(self, "_ds", None), *self._keep] if t is not None]
        self._ds, self._keep = None, []
        if things:
            with gdal_env():
                for thing in things:
                    try:
                        thing.close()
                    except Exception:  # closing must not hide the error that made us close
                        pass


def open_heightmap(path: str, spec: HeightmapSpec | None = None, fmt: str | None = None, band: int | None = None):
    """The heightmap at ``path`` ("-": standard input, with ``fmt``) as a DEM source."""
    kind = heightmap_format(path, fmt)
    band = band if band is not None else (spec.band if spec is not None else None)
    if path == "-" and not fmt:
        raise InputError("<stdin>", "reading a heightmap from standard input needs --format (png, raw, r16, r32)")
    if kind in PNG_SUFFIXES:
        return PngHeightmap(path, spec, band)
    if kind in RAW_SUFFIXES:
        if band not in (None, 1):
            raise InputError("<stdin>" if path == "-" else path, "--band applies to PNG channels; a RAW has one")
        return RawHeightmap(path, kind, spec)
    raise InputError("<stdin>" if path == "-" else path,
                     f"unknown heightmap format {kind!r}; known: {', '.join(HEIGHTMAP_SUFFIXES)}")
