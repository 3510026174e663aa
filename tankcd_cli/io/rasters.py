"""Raster DEMs of any format GDAL reads, served as a metric grid of posts, window by window.

What it reads: GeoTIFF (tiled, striped, Cloud-Optimized), DTED level 0-2, SRTM HGT (also
zipped: ``N45E006.hgt.zip`` or any ``.zip`` holding rasters), ESRI ASCII grids, ERDAS IMAGINE,
VRT mosaics, a folder of tiles, and whatever else the installed GDAL opens (``fmt`` names the
driver). rasterio is imported inside the functions only, so the CLI starts without it.

Posts: a post is a pixel centre, so post [0, 0] (the north-west one) is at
``transform * (0.5, 0.5)`` and post (r, c) at ``x = ox + c*dx, y = oy - r*dy``. GDAL already
reports DTED and SRTM HGT with a transform whose pixel centres are the posts, so they follow
the same rule unchanged.

Grids are metric, in ground metres:
- a projected CRS in metres is kept as it is where its point scale (pyproj's meridional and
  parallel scales at the centre, the corners and the edges' midpoints: ``point_scale``) is
  within ``SCALE_TOLERANCE`` (1 %) of 1; otherwise (Web Mercator: 1 / cos(latitude)) it is
  warped to the UTM zone of its centre, as a geographic CRS is, with a SetupWarning naming the
  scale; its post spacing is then the source's in ground metres (over the meridional scale);
- a geographic CRS (degrees) is warped to the UTM zone of the raster's centre (WGS 84,
  EPSG:326xx north / 327xx south, plain 6-degree zones without the Norway/Svalbard
  exceptions), or to ``crs`` when given. UTM needs the centre between 80 S and 84 N and at
  most 18 degrees (three zones) of longitude; otherwise name a CRS;
- ``crs`` given for a projected source warps it too; a projected CRS in feet needs ``crs``;
- the warped grid has square posts: the source's north-south post spacing in metres (at the
  centre latitude on the WGS 84 ellipsoid, or the projected spacing times its unit) rounded
  to 3 significant digits (1" -> 30.9 m, 3" -> 92.6 m, 30" -> 926 m). Posts sit on whole
  multiples of that spacing, so tiles of one area warp onto one lattice, and the grid is the
  smallest such box holding every source post. A warped post's height is the bilinear
  interpolation between the four source posts around it (NODATA posts left out of the weights),
  NaN outside the source;
- a raster without a CRS is a local metric grid; one without any geotransform is a local grid
  of 1 m posts with the south-west post at (0, 0), named so in ``crs_name``.

Memory: ``read`` touches only the GDAL blocks under its window; GDAL's block cache is held to
64 MB and warping to 64 MB chunks. The GDAL options are entered around every open and read
(not held across calls) so they hold whichever thread reads and sources closed out of order
do not unwind each other's settings. Standard input is the one exception to windowed reading:
it cannot seek, so its bytes are held in memory.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import sys
import warnings
import zipfile
from dataclasses import dataclass
from xml.etree import ElementTree

import numpy as np

from tankcd_cli.errors import InputError, warn
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.dem_source import DemSourceInfo

RASTER_SUFFIXES: tuple[str, ...] = ("tif", "tiff", "gtif", "dt0", "dt1", "dt2", "hgt", "hgt.zip", "zip", "asc",
                                    "vrt", "img", "bil", "flt", "dem")

# what a folder or a zip archive may hold as tiles
_TILE_SUFFIXES = tuple(s for s in RASTER_SUFFIXES if s not in ("zip", "hgt.zip", "vrt"))

# format names (suffixes and aliases) -> GDAL driver; any other GDAL driver name works as is
_DRIVERS = {"tif": "GTiff", "tiff": "GTiff", "gtif": "GTiff", "geotiff": "GTiff", "gtiff": "GTiff", "cog": "GTiff",
            "dt0": "DTED", "dt1": "DTED", "dt2": "DTED", "dted": "DTED", "hgt": "SRTMHGT", "srtmhgt": "SRTMHGT",
            "asc": "AAIGrid", "aaigrid": "AAIGrid", "vrt": "VRT", "img": "HFA", "hfa": "HFA",
            "bil": "EHdr", "flt": "EHdr", "ehdr": "EHdr", "dem": "USGSDEM", "usgsdem": "USGSDEM"}

CACHE_BYTES = 64 * 2**20   # GDAL block cache; rasterio takes GDAL_CACHEMAX in bytes
WARP_MEM_MB = 64
WARP_TOLERANCE = 0.01      # source pixels; GDAL's default 1/8 pixel shifts heights visibly on steep ground
_HASH_BLOCK = 2**20

_GDAL_OPTIONS = {
    "GDAL_CACHEMAX": CACHE_BYTES,
    "DTED_VERIFY_CHECKSUM": "YES",        # a damaged DTED record fails its read instead of giving wrong heights
    "AAIGRID_DATATYPE": "Float64",        # GDAL otherwise rounds decimal ASCII grids to float32
    "GRASSASCIIGRID_DATATYPE": "Float64",
}

_EXACT_IN_FLOAT32 = ("int8", "uint8", "int16", "uint16", "float32")


class RasterSource:
    """An open raster DEM; ``read`` windows of heights. A context manager; not for sharing between threads.

    grid : the metric grid ``read`` serves (after any reprojection)
    info : where it came from: the source's format, band, NODATA, block, SHA-256, own CRS
    """

    def __init__(self, grid: PostGrid, info: DemSourceInfo, dataset, reader, keep: list):
        self.grid = grid
        self.info = info
        self._dataset = dataset      # the source as GDAL opened it
        self._reader = reader        # what read() reads: the dataset, or a WarpedVRT over it
        self._keep = keep            # memory files and the like, closed last
        self._closed = False

    def __enter__(self) -> "RasterSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        with gdal_env():
            for thing in [self._reader, self._dataset, *self._keep]:
                try:
                    thing.close()
                except Exception:  # closing must not hide the error that made us close
                    pass

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """float64 (r1-r0, c1-c0) heights, row 0 north; NaN at NODATA and outside the raster
        (the window may extend past any edge, even wholly outside)."""
        if self._closed:
            raise ValueError("read from a closed raster")
        r0, r1, c0, c1 = int(r0), int(r1), int(c0), int(c1)
        if r1 < r0 or c1 < c0:
            raise ValueError(f"inverted window rows {r0}-{r1} cols {c0}-{c1}")
        out = np.full((r1 - r0, c1 - c0), np.nan)
        a0, a1 = max(r0, 0), min(r1, self.grid.rows)
        b0, b1 = max(c0, 0), min(c1, self.grid.cols)
        if a0 >= a1 or b0 >= b1:
            return out
        from rasterio.windows import Window

        window = Window(b0, a0, b1 - b0, a1 - a0)
        with gdal_env():
            try:
                if self._reader is self._dataset:
                    heights = _read_native(self._dataset, self.info.band, window)
                else:  # the warp already gives float64 with NaN for NODATA and outside
                    heights = self._reader.read(self.info.band, window=window)
            except Exception as exc:
                if not is_gdal_error(exc):
                    raise
                raise InputError(self.info.source, f"rows {a0}-{a1} cols {b0}-{b1}: {gdal_message(exc)}") from None
        heights[~np.isfinite(heights)] = np.nan  # no ground is infinitely high: treat it as missing
        out[a0 - r0:a1 - r0, b0 - c0:b1 - c0] = heights
        return out


def is_raster(path: str) -> bool:
    """Whether ``path`` is a raster DEM input to open with :func:`open_raster` (suffix, folder of tiles, magic bytes)."""
    if path == "-":
        return False
    if os.path.isdir(path):
        try:
            return any(_suffix(e.name) in _TILE_SUFFIXES + ("zip", "hgt.zip") for e in os.scandir(path) if e.is_file())
        except OSError:
            return False
    if _suffix(path) in RASTER_SUFFIXES:
        return True
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return False
    return head[:4] in (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+") or head.startswith(
        (b"UHL1", b"HDR1", b"VOL1", b"<VRTDataset", b"EHFA_HEADER_TAG"))


def open_raster(path: str, band: int | None = None, crs: str | None = None, fmt: str | None = None) -> RasterSource:
    """Open a raster DEM as a metric grid of posts.

    path : a file, a folder of tiles, a ``.zip``, or "-" for standard input (then ``fmt`` is needed)
    band : the band holding heights (from 1); needed when the raster has several
    crs : a projected metric CRS to warp to (anything rasterio's CRS.from_user_input takes)
    fmt : format overriding the suffix: a suffix ("tif", "dt1", "hgt", "asc", "vrt", "zip", ...)
        or a GDAL driver name; ignored for a folder
    """
    name = "<stdin>" if path == "-" else path
    fmt = fmt.lower().lstrip(".") if fmt else None
    keep: list = []
    try:
        gdal_path, digest, driver = _locate(path, name, fmt, keep)
        dataset = _open_dataset(gdal_path, name, driver)
        keep.insert(0, dataset)
        source = _build(dataset, name, digest, band, crs, keep[1:])
    except BaseException:
        with gdal_env():
            for thing in keep:
                try:
                    thing.close()
                except Exception:
                    pass
        raise
    return source


# --- locating the input ---------------------------------------------------------

def _suffix(path: str) -> str:
    low = os.path.basename(path).lower()
    if low.endswith(".hgt.zip"):
        return "hgt.zip"
    return os.path.splitext(low)[1].lstrip(".")


def _driver_for(fmt: str, name: str) -> str:
    if fmt in _DRIVERS:
        return _DRIVERS[fmt]
    with gdal_env() as env:
        drivers = env.drivers()
    for driver in drivers:
        if driver.lower() == fmt:
            return driver
    raise InputError(name, f"unknown raster format {fmt!r}; known: {', '.join(RASTER_SUFFIXES)} or a GDAL driver name")


def _locate(path: str, name: str, fmt: str | None, keep: list) -> tuple[str, str, str | None]:
    """(path for GDAL, sha256, GDAL driver to insist on or None) of the input."""
    if path == "-":
        return _from_stdin(name, fmt, keep)
    if not os.path.exists(path):
        raise InputError(name, "no such file")
    if os.path.isdir(path):
        return _mosaic_folder(path, name, keep)
    kind = fmt or _suffix(path)
    if kind in ("zip", "hgt.zip"):
        return _from_zip(path, name, keep)
    driver = _driver_for(fmt, name) if fmt else None
    if kind == "vrt" or (fmt is None and _starts_with(path, b"<VRTDataset")):
        return path, _vrt_digest(path, name), driver
    return path, file_sha256(path, name), driver


def _starts_with(path: str, magic: bytes) -> bool:
    try:
        with open(path, "rb") as fh:
            return fh.read(len(magic) + 8).lstrip().startswith(magic)
    except OSError:
        return False


def file_sha256(path: str, name: str) -> str:
    """The SHA-256 of a file's bytes, read in blocks (``name`` is how errors name it)."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            while block := fh.read(_HASH_BLOCK):
                digest.update(block)
    except FileNotFoundError:
        raise InputError(name, "no such file") from None
    except PermissionError:
        raise InputError(name, "permission denied") from None
    except OSError as exc:
        raise InputError(name, f"cannot read: {exc.strerror or exc}") from None
    return digest.hexdigest()


def _list_digest(entries: list[tuple[str, str]]) -> str:
    """sha256 of the lines "<sha256>  <name>" (as sha256sum prints them), sorted by name."""
    text = "".join(f"{sha}  {entry}\n" for entry, sha in sorted(set(entries)))
    return hashlib.sha256(text.encode("utf-8", "surrogateescape")).hexdigest()


def _from_stdin(name: str, fmt: str | None, keep: list) -> tuple[str, str, str | None]:
    from rasterio.io import MemoryFile

    if fmt is None:
        raise InputError(name, "reading a raster from standard input needs --format")
    why = {"vrt": "it names other files", "zip": "an archive needs seeking", "hgt.zip": "an archive needs seeking",
           "hgt": "its position is in its file name", "srtmhgt": "its position is in its file name"}.get(fmt)
    if why:
        raise InputError(name, f"a {fmt} raster cannot come from standard input ({why}): give its path")
    driver = _driver_for(fmt, name)
    try:
        data = sys.stdin.buffer.read()
    except OSError as exc:
        raise InputError(name, f"cannot read: {exc.strerror or exc}") from None
    if not data:
        raise InputError(name, "file is empty")
    with gdal_env():
        memfile = MemoryFile(data, ext="." + fmt if fmt in _DRIVERS else "")
    keep.append(memfile)
    return memfile.name, hashlib.sha256(data).hexdigest(), driver


def _zip_members(path: str, name: str) -> list[str]:
    try:
        with zipfile.ZipFile(path) as archive:
            members = [m for m in archive.namelist() if not m.endswith("/")]
    except (zipfile.BadZipFile, OSError, EOFError) as exc:
        raise InputError(name, f"not a readable zip archive: {exc}") from None
    return [m for m in members if _suffix(m) in _TILE_SUFFIXES]


def _from_zip(path: str, name: str, keep: list) -> tuple[str, str, str | None]:
    members = _zip_members(path, name)
    if not members:
        raise InputError(name, "the zip archive holds no raster (" + ", ".join(_TILE_SUFFIXES) + ")")
    digest = file_sha256(path, name)
    vsi = "/vsizip/" + os.path.abspath(path)
    if len(members) == 1:
        return f"{vsi}/{members[0]}", digest, None
    tiles = [(f"{os.path.basename(path)}/{m}", f"{vsi}/{m}") for m in sorted(members)]
    return _mosaic(tiles, name, keep), digest, None


def _mosaic_folder(path: str, name: str, keep: list) -> tuple[str, str, str | None]:
    """Tiles are the folder's files with raster suffixes (a .zip counts by its rasters); a .vrt
    in the folder is left out (pass it itself to use it); subfolders are not searched."""
    try:
        entries = sorted(e.name for e in os.scandir(path) if e.is_file())
    except OSError as exc:
        raise InputError(name, f"cannot list the folder: {exc.strerror or exc}") from None
    tiles: list[tuple[str, str]] = []
    hashes: list[tuple[str, str]] = []
    for entry in entries:
        kind = _suffix(entry)
        full = os.path.join(path, entry)
        if kind in ("zip", "hgt.zip"):
            members = _zip_members(full, full)
            tiles += [(f"{entry}/{m}", f"/vsizip/{os.path.abspath(full)}/{m}") for m in sorted(members)]
            if members:
                hashes.append((entry, file_sha256(full, full)))
        elif kind in _TILE_SUFFIXES:
            tiles.append((entry, os.path.abspath(full)))
            hashes.append((entry, file_sha256(full, full)))
    if not tiles:
        raise InputError(name, "the folder holds no raster tiles (" + ", ".join(("zip",) + _TILE_SUFFIXES) + ")")
    return _mosaic(tiles, name, keep), _list_digest(hashes), None


def _vrt_digest(path: str, name: str) -> str:
    """Check every file the VRT names exists; hash the VRT text and those files."""
    entries = [(os.path.basename(path), file_sha256(path, name))]
    try:
        root = ElementTree.parse(path).getroot()
    except ElementTree.ParseError as exc:
        raise InputError(name, f"not a valid VRT (XML): {exc}") from None
    except OSError as exc:
        raise InputError(name, f"cannot read: {exc.strerror or exc}") from None
    base = os.path.dirname(os.path.abspath(path))
    for element in root.iter():
        if element.tag not in ("SourceFilename", "SourceDataset") or not (element.text or "").strip():
            continue
        written = element.text.strip()
        if written.startswith("/vsi") or "://" in written or written.startswith("<"):
            continue  # virtual, remote or inline: GDAL reports those itself when they fail
        relative = element.get("relativeToVRT", "0") == "1"
        full = os.path.join(base, written) if relative and not os.path.isabs(written) else written
        if not os.path.isfile(full):
            raise InputError(name, f"the VRT names a missing file: {written}")
        entries.append((written, file_sha256(full, name + ": " + written)))
    return _list_digest(entries)


# --- a mosaic of tiles, as a VRT in memory --------------------------------------

def _mosaic(tiles: list[tuple[str, str]], name: str, keep: list) -> str:
    """Write a VRT mosaic of ``tiles`` [(display name, GDAL path)] into memory; return its path.

    All tiles must share CRS, post spacing, band count and post lattice; each keeps its own NODATA.
    """
    from xml.sax.saxutils import escape, quoteattr  # here: it loads urllib.request, http and ssl

    import rasterio
    from rasterio.io import MemoryFile

    metas = []
    with gdal_env():
        for shown, gdal_path in tiles:
            try:
                with quiet_warnings(), rasterio.open(gdal_path) as ds:
                    metas.append(dict(name=shown, path=gdal_path, crs=ds.crs, t=ds.transform, w=ds.width, h=ds.height,
                                      count=ds.count, dtypes=ds.dtypes, nodatas=ds.nodatavals,
                                      blocks=ds.block_shapes))
            except Exception as exc:
                if not is_gdal_error(exc):
                    raise
                raise InputError(name, f"tile {shown}: not a raster GDAL can read: {gdal_message(exc)}") from None
    first = metas[0]
    t0 = first["t"]
    for m in metas:
        t = m["t"]
        if t.b != 0 or t.d != 0 or t.a <= 0 or t.e >= 0:
            raise InputError(name, f"tile {m['name']}: not a north-up grid (geotransform {tuple(t)[:6]})")
        if m["crs"] != first["crs"]:
            raise InputError(name, f"tile {m['name']} has CRS {crs_name(m['crs'])}, tile {first['name']} "
                                   f"{crs_name(first['crs'])}: all tiles must share one")
        if not (math.isclose(t.a, t0.a, rel_tol=1e-7) and math.isclose(t.e, t0.e, rel_tol=1e-7)):
            raise InputError(name, f"tile {m['name']} has post spacing {t.a:g} x {-t.e:g}, tile {first['name']} "
                                   f"{t0.a:g} x {-t0.e:g}: all tiles must share one")
        if m["count"] != first["count"]:
            raise InputError(name, f"tile {m['name']} has {m['count']} bands, tile {first['name']} "
                                   f"{first['count']}: all tiles must have the same")
        offset_x, offset_y = (t.c - t0.c) / t0.a, (t.f - t0.f) / t0.e
        if abs(offset_x - round(offset_x)) > 1e-3 or abs(offset_y - round(offset_y)) > 1e-3:
            raise InputError(name, f"tile {m['name']} is off the post lattice of tile {first['name']} "
                                   f"(shifted by a fraction of a post)")
        m["x"], m["y"] = round(offset_x), round(offset_y)
    x_min = min(m["x"] for m in metas)
    y_min = min(m["y"] for m in metas)
    width = max(m["x"] + m["w"] for m in metas) - x_min
    height = max(m["y"] + m["h"] for m in metas) - y_min
    left, top = t0.c + x_min * t0.a, t0.f + y_min * t0.e

    lines = [f'<VRTDataset rasterXSize="{width}" rasterYSize="{height}">']
    if first["crs"] is not None:
        # no axis mapping given: GDAL then reads x, y in GIS order (longitude first), as rasterio writes it
        lines.append(f'  <SRS>{escape(first["crs"].to_wkt())}</SRS>')
    lines.append(f"  <GeoTransform>{left!r}, {t0.a!r}, 0, {top!r}, 0, {t0.e!r}</GeoTransform>")
    for b in range(first["count"]):
        types = {m["dtypes"][b] for m in metas}
        dtype = types.pop() if len(types) == 1 else "float64"
        nodata = next((m["nodatas"][b] for m in metas if m["nodatas"][b] is not None), None)
        block_rows, block_cols = first["blocks"][b]
        lines.append(f'  <VRTRasterBand dataType="{_gdal_type(dtype)}" band="{b + 1}" '
                     f'blockXSize="{min(block_cols, 8192)}" blockYSize="{min(block_rows, 8192)}">')
        if nodata is not None:
            lines.append(f"    <NoDataValue>{_number(nodata)}</NoDataValue>")
        for m in metas:
            rows, cols = m["blocks"][b]
            lines += ["    <ComplexSource>",
                      f'      <SourceFilename relativeToVRT="0">{escape(m["path"])}</SourceFilename>',
                      f"      <SourceBand>{b + 1}</SourceBand>",
                      f'      <SourceProperties RasterXSize="{m["w"]}" RasterYSize="{m["h"]}" '
                      f'DataType={quoteattr(_gdal_type(m["dtypes"][b]))} BlockXSize="{cols}" BlockYSize="{rows}"/>',
                      f'      <SrcRect xOff="0" yOff="0" xSize="{m["w"]}" ySize="{m["h"]}"/>',
                      f'      <DstRect xOff="{m["x"] - x_min}" yOff="{m["y"] - y_min}" xSize="{m["w"]}" ySize="{m["h"]}"/>']
            if m["nodatas"][b] is not None:  # the tile's own NODATA posts let the ones below show through
                lines.append(f"      <NODATA>{_number(m['nodatas'][b])}</NODATA>")
            lines.append("    </ComplexSource>")
        lines.append("  </VRTRasterBand>")
    lines.append("</VRTDataset>")
    with gdal_env():
        memfile = MemoryFile("\n".join(lines).encode("utf-8", "surrogateescape"), ext=".vrt")
    keep.append(memfile)
    return memfile.name


def _gdal_type(dtype: str) -> str:
    return {"uint8": "Byte", "int8": "Int8", "uint16": "UInt16", "int16": "Int16", "uint32": "UInt32",
            "int32": "Int32", "uint64": "UInt64", "int64": "Int64", "float32": "Float32",
            "float64": "Float64"}.get(dtype, "Float64")


def _number(value: float) -> str:
    if math.isnan(value):
        return "nan"
    return repr(int(value)) if float(value).is_integer() and abs(value) < 2**53 else repr(float(value))


# --- opening and checking -------------------------------------------------------

def gdal_env():
    """rasterio's GDAL environment with tankcd's options (64 MB block cache, checksums, float64 ASCII grids)."""
    import rasterio

    return rasterio.Env(**_GDAL_OPTIONS)


class quiet_warnings(warnings.catch_warnings):
    """Silence rasterio's Python warnings (NotGeoreferencedWarning): we report such rasters ourselves."""

    def __enter__(self):
        result = super().__enter__()
        warnings.simplefilter("ignore")
        return result


def is_gdal_error(exc: BaseException) -> bool:
    """Whether ``exc`` is GDAL's (through rasterio), not a bug of ours."""
    from rasterio._err import CPLE_BaseError
    from rasterio.errors import RasterioError

    return isinstance(exc, (RasterioError, CPLE_BaseError))


def gdal_message(exc: BaseException) -> str:
    """GDAL's own words: rasterio hides them behind 'See previous exception' in the cause chain."""
    messages = []
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        text = str(exc.args[-1] if type(exc).__name__.startswith("CPLE_") and exc.args else exc).strip()
        if text and "See previous exception" not in text:
            messages.append(text)
        exc = exc.__cause__ or exc.__context__
    text = messages[-1] if messages else "GDAL could not read it"
    return " ".join(text.split())[:300]


def _open_dataset(gdal_path: str, name: str, driver: str | None):
    import rasterio

    with gdal_env(), quiet_warnings():
        try:
            return rasterio.open(gdal_path, driver=driver) if driver else rasterio.open(gdal_path)
        except Exception as exc:
            if not is_gdal_error(exc):
                raise
            what = f"not a {driver} raster GDAL can read" if driver else "not a raster GDAL can read"
            raise InputError(name, f"{what}: {gdal_message(exc)}") from None


_WKT_NAME = re.compile(r'^\s*[A-Za-z_0-9]+\[\s*"([^"]*)"')


def crs_name(crs) -> str:
    """A CRS in words: the name its WKT gives, else its PROJ or EPSG string."""
    if crs is None:
        return "local grid (no CRS)"
    match = _WKT_NAME.match(crs.to_wkt())
    if match and match.group(1) not in ("", "unknown", "unnamed"):
        return match.group(1)
    return crs.to_string() or "unnamed CRS"


def metric_crs(crs: str, name: str):
    """The rasterio CRS of ``crs`` (anything ``CRS.from_user_input`` takes), refused unless it is
    projected and in metres (``name``: the input errors name)."""
    from rasterio.crs import CRS

    try:
        dst = CRS.from_user_input(crs)
    except Exception as exc:
        raise InputError(name, f"--crs {crs!r} is not a CRS: {gdal_message(exc)}") from None
    if not dst.is_projected:
        raise InputError(name, f"--crs {crs!r} ({crs_name(dst)}) is not a projected CRS: the grid must be in metres")
    unit, factor = dst.linear_units_factor
    if abs(factor - 1.0) > 1e-12:
        raise InputError(name, f"--crs {crs!r} ({crs_name(dst)}) is in {unit}: the grid must be in metres")
    return dst


def _build(ds, name: str, digest: str, band: int | None, crs: str | None, keep: list) -> RasterSource:
    if ds.count < 1:
        raise InputError(name, "the raster has no bands")
    if band is None:
        if ds.count > 1:
            raise InputError(name, f"the raster has {ds.count} bands: choose the heights with --band 1..{ds.count}")
        band = 1
    if not 1 <= band <= ds.count:
        raise InputError(name, f"--band {band} is out of range: the raster has {ds.count} band"
                               f"{'s' if ds.count > 1 else ''} (1..{ds.count})")
    if ds.width < 2 or ds.height < 2:
        raise InputError(name, f"a {ds.height} x {ds.width} raster is too small: needs at least 2 x 2 posts")
    t = ds.transform
    georeferenced = not t.is_identity
    if not georeferenced and ds.gcps[0]:
        raise InputError(name, "georeferenced by ground control points only: warp it to a north-up grid first, "
                               "e.g. gdalwarp")
    if georeferenced:
        if t.b != 0 or t.d != 0:
            raise InputError(name, "rotated geotransform (terms b, d non-zero): warp it to north-up first, e.g. gdalwarp")
        if t.e >= 0 or t.a <= 0:
            raise InputError(name, f"{'south-up' if t.e >= 0 else 'mirrored'} geotransform "
                                   f"(pixel size {t.a:g}, {t.e:g}): warp it to north-up first, e.g. gdalwarp")
    _probe(ds, name, band)

    src_crs = ds.crs if georeferenced and ds.crs is not None else None
    if not georeferenced:
        source_crs_name = "local grid (no georeferencing; 1 m posts assumed)"
    else:
        source_crs_name = crs_name(src_crs)
    dst = None
    if crs is not None:
        dst = metric_crs(crs, name)
        if src_crs is None:
            raise InputError(name, f"the raster has no CRS, so it cannot be warped to --crs {crs!r}")
        if dst == src_crs:
            dst = None
    elif src_crs is not None and src_crs.is_geographic:
        dst = _utm_for(ds, name)
    elif src_crs is not None:
        unit, factor = src_crs.linear_units_factor
        if abs(factor - 1.0) > 1e-12:
            raise InputError(name, f"CRS {crs_name(src_crs)} is in {unit}; give --crs to reproject")
    scale = point_scale(src_crs, _post_bounds(ds)) if src_crs is not None and src_crs.is_projected else None
    if dst is None and crs is None and scale is not None and scale.off_by > SCALE_TOLERANCE:
        dst = _utm_zone(scale.lon, scale.lat, scale.lon_span, name)
        warn(name, f"{crs_label(src_crs)} metres are {1 / scale.centre:.2f} ground metres here (point scale "
                   f"{scale.centre:.2f} at the centre{scale.range_text()}): reprojected to {crs_label(dst)}; "
                   "give --crs to choose another")

    common = dict(source=name, format=ds.driver, nodata=ds.nodatavals[band - 1], dtype=ds.dtypes[band - 1],
                  band=band, bands=ds.count, sha256=digest,
                  height_dtype="float32" if ds.dtypes[band - 1] in _EXACT_IN_FLOAT32 else "float64",
                  source_crs_name=source_crs_name, source_crs_wkt=src_crs.to_wkt() if src_crs is not None else "",
                  source_point_scale=scale.centre if scale is not None else 0.0,
                  source_point_scale_range=(scale.low, scale.high) if scale is not None else (0.0, 0.0))
    if dst is None:
        block = tuple(int(v) for v in ds.block_shapes[band - 1])
        if georeferenced:
            origin = (t.c + 0.5 * t.a, t.f + 0.5 * t.e)
            spacing = (t.a, -t.e)
            crs_wkt, grid_crs = (src_crs.to_wkt(), source_crs_name) if src_crs is not None else ("", "local grid (no CRS)")
        else:  # GDAL's identity transform: read it north-up with 1 m posts, the south-west one at (0, 0)
            origin, spacing = (0.0, float(ds.height - 1)), (1.0, 1.0)
            crs_wkt, grid_crs = "", source_crs_name
        grid = PostGrid(ds.height, ds.width, float(origin[0]), float(origin[1]), float(spacing[0]), float(spacing[1]),
                        crs_wkt, grid_crs)
        source = RasterSource(grid, DemSourceInfo(reprojected=False, block=(block[0], block[1]), **common), ds, ds,
                              keep)
    else:
        source = _warped(ds, name, src_crs, dst, common, keep, scale)
    if crs is not None:
        try:
            _warn_of_chosen_scale(source.grid, crs, name)
        except BaseException:  # --strict: the warning is an error; the warp goes with the source
            source.close()
            raise
    return source


def _warn_of_chosen_scale(grid: PostGrid, crs: str, name: str) -> None:
    """A SetupWarning when the CRS ``--crs`` chose has metres that stray over 1 % from ground
    metres over the grid (kept: the user asked for it)."""
    from rasterio.crs import CRS

    target = CRS.from_wkt(grid.crs_wkt)
    south, east = grid.origin_y - (grid.rows - 1) * grid.dy, grid.origin_x + (grid.cols - 1) * grid.dx
    scale = point_scale(target, (grid.origin_x, south, east, grid.origin_y))
    if scale is not None and scale.off_by > SCALE_TOLERANCE:
        warn(name, f"--crs {crs}: its metres are {1 / scale.centre:.2f} ground metres here (point scale "
                   f"{scale.centre:.2f} at the centre{scale.range_text()}): kept as asked, so slopes and distances "
                   "are off by that much")


def _probe(ds, name: str, band: int) -> None:
    """Read the first and the last block: a cut-short file (the usual damage) fails here, at open."""
    from rasterio.windows import Window

    with gdal_env():
        for row, col in ((0, 0), (ds.height - 1, ds.width - 1)):
            try:
                ds.read(band, window=Window(col, row, 1, 1))
            except Exception as exc:
                if not is_gdal_error(exc):
                    raise
                raise InputError(name, f"damaged raster (reading row {row} col {col}): {gdal_message(exc)}") from None


# metres per degree of latitude on the WGS 84 ellipsoid (meridional radius of curvature)
_WGS84_A = 6378137.0
_WGS84_E2 = 6.69437999014e-3


def _metres_per_degree_lat(lat: float) -> float:
    s = math.sin(math.radians(lat))
    return _WGS84_A * (1 - _WGS84_E2) / (1 - _WGS84_E2 * s * s) ** 1.5 * math.pi / 180


def _post_bounds(ds) -> tuple[float, float, float, float]:
    """(west, south, east, north) of the outermost posts, in the source CRS."""
    t = ds.transform  # north-up by now: b = d = 0
    return t.c + 0.5 * t.a, t.f + (ds.height - 0.5) * t.e, t.c + (ds.width - 0.5) * t.a, t.f + 0.5 * t.e


def _utm_for(ds, name: str):
    west, south, east, north = _post_bounds(ds)
    return _utm_zone((west + east) / 2, (south + north) / 2, east - west, name)


def _utm_zone(lon: float, lat: float, lon_span: float, name: str):
    """The WGS 84 UTM zone of a centre (lon, lat) deg, for an extent ``lon_span`` degrees wide."""
    from rasterio.crs import CRS

    if not -80 <= lat <= 84:
        pole = "EPSG:32661 (UPS North)" if lat > 0 else "EPSG:32761 (UPS South)"
        raise InputError(name, f"centre latitude {lat:.2f} is outside UTM (80S to 84N): give --crs, e.g. {pole}")
    if lon_span > 18:
        raise InputError(name, f"spans {lon_span:.1f} degrees of longitude, too wide for one UTM zone: "
                               "give --crs with a projected CRS in metres")
    zone = int(((lon + 180) % 360) // 6) + 1
    return CRS.from_epsg((32600 if lat >= 0 else 32700) + min(zone, 60))


SCALE_TOLERANCE = 0.01  # a projected CRS whose scale strays further from 1 than this is reprojected


@dataclass(frozen=True)
class PointScale:
    """How long a projected CRS's metre is on the ground over a raster: its point scale (projected
    length over ellipsoid length, pyproj's ``Factors``) at the centre and the outermost posts.

    centre : sqrt(areal scale) at the centre (the meridional and parallel scales' geometric mean;
        either of them for a conformal projection): one CRS metre is 1 / centre ground metres
    meridional, parallel : the scales along the meridian and the parallel at the centre
    low, high : the least and greatest meridional or parallel scale at the centre, the four
        corners and the four edge midpoints
    lon, lat, lon_span : the centre and the longitudes spanned, degrees in the CRS's own datum
    """

    centre: float
    meridional: float
    parallel: float
    low: float
    high: float
    lon: float
    lat: float
    lon_span: float

    @property
    def off_by(self) -> float:
        """The largest |scale - 1| anywhere it was measured."""
        return max(abs(self.low - 1.0), abs(self.high - 1.0))

    def range_text(self) -> str:
        if self.high - self.low < 0.005:
            return ""
        return f", {self.low:.3g} to {self.high:.3g} over the extent"


def point_scale(src_crs, bounds: tuple[float, float, float, float]) -> PointScale | None:
    """The :class:`PointScale` of the projected CRS ``src_crs`` (rasterio's) over the posts'
    ``bounds`` (west, south, east, north in the CRS), or None where pyproj cannot say (a point off
    the projection's domain, a CRS without an inverse)."""
    from pyproj import CRS, Proj, Transformer

    try:
        crs = CRS.from_wkt(src_crs.to_wkt())
        west, south, east, north = bounds
        mx, my = (west + east) / 2, (south + north) / 2
        xs = np.array([mx, west, east, east, west, mx, east, mx, west])
        ys = np.array([my, south, south, north, north, south, my, north, my])
        lon, lat = Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True).transform(xs, ys)
        lon, lat = np.asarray(lon, dtype=float), np.asarray(lat, dtype=float)
        if not (np.isfinite(lon).all() and np.isfinite(lat).all()):
            return None
        f = Proj(crs).get_factors(lon, lat)
        meridional = np.asarray(f.meridional_scale, dtype=float)
        parallel = np.asarray(f.parallel_scale, dtype=float)
        areal = np.asarray(f.areal_scale, dtype=float)
    except Exception:  # pyproj's errors vary by version; no scale known: the grid is kept as it is
        return None
    both = np.concatenate([meridional, parallel])
    if not (np.isfinite(both).all() and np.isfinite(areal[0]) and (both > 0).all() and areal[0] > 0):
        return None
    span = float(np.ptp(np.mod(lon - lon[0] + 180.0, 360.0)))  # across the antimeridian too
    return PointScale(float(np.sqrt(areal[0])), float(meridional[0]), float(parallel[0]), float(both.min()),
                      float(both.max()), float(lon[0]), float(lat[0]), span)


def crs_label(crs) -> str:
    """A CRS as short as it goes: ``EPSG:3857``, else its name."""
    code = crs.to_epsg() if crs is not None else None
    return f"EPSG:{code}" if code else crs_name(crs)


def _warped(ds, name: str, src_crs, dst, common: dict, keep: list, scale: PointScale | None = None) -> RasterSource:
    from affine import Affine
    from rasterio.enums import Resampling
    from rasterio.vrt import WarpedVRT
    from rasterio.warp import transform_bounds

    t = ds.transform
    west, south, east, north = _post_bounds(ds)
    if src_crs.is_geographic:
        metres = abs(t.e) * _metres_per_degree_lat((south + north) / 2)
    else:
        metres = abs(t.e) * src_crs.linear_units_factor[1]
        if scale is not None and scale.off_by > SCALE_TOLERANCE:
            metres /= scale.meridional  # the CRS's metres along the meridian are 1 / scale ground metres
    step = float(f"{metres:.3g}")
    with gdal_env():
        try:
            xmin, ymin, xmax, ymax = transform_bounds(src_crs, dst, west, south, east, north, densify_pts=101)
        except Exception as exc:
            raise InputError(name, f"cannot transform the raster's extent to {crs_name(dst)}: "
                                   f"{gdal_message(exc)}") from None
    if not all(math.isfinite(v) for v in (xmin, ymin, xmax, ymax)):
        raise InputError(name, f"the raster's extent does not transform to {crs_name(dst)}: give another --crs")
    # posts on whole multiples of the step, a box just holding every source post
    x0 = math.floor(xmin / step + 1e-9) * step
    y0 = math.ceil(ymax / step - 1e-9) * step
    cols = int(round((math.ceil(xmax / step - 1e-9) * step - x0) / step)) + 1
    rows = int(round((y0 - math.floor(ymin / step + 1e-9) * step) / step)) + 1
    if rows < 2 or cols < 2:
        raise InputError(name, f"warped to {crs_name(dst)} it is {rows} x {cols} posts: needs at least 2 x 2 posts")
    transform = Affine(step, 0, x0 - step / 2, 0, -step, y0 + step / 2)
    with gdal_env():
        try:
            # XSCALE/YSCALE 1: plain bilinear between the four nearest posts; GDAL would otherwise widen
            # the kernel where the metric posts are sparser than the source's, smoothing the ground
            vrt = WarpedVRT(ds, crs=dst, transform=transform, width=cols, height=rows, resampling=Resampling.bilinear,
                            nodata=float("nan"), dtype="float64", tolerance=WARP_TOLERANCE,
                            warp_mem_limit=WARP_MEM_MB, XSCALE=1, YSCALE=1)
        except Exception as exc:
            if not is_gdal_error(exc):
                raise
            raise InputError(name, f"cannot warp to {crs_name(dst)}: {gdal_message(exc)}") from None
        block = tuple(int(v) for v in vrt.block_shapes[common["band"] - 1])
    grid = PostGrid(rows, cols, x0, y0, step, step, dst.to_wkt(), crs_name(dst))
    return RasterSource(grid, DemSourceInfo(reprojected=True, block=(block[0], block[1]), **common), ds, vrt, keep)


def _read_native(ds, band: int, window) -> np.ndarray:
    """The window as float64 with NaN at NODATA (compared in the band's own type, as GDAL does)
    and where the dataset's mask says so."""
    from rasterio.enums import MaskFlags

    raw = ds.read(band, window=window)
    heights = raw.astype(np.float64)
    nodata = ds.nodatavals[band - 1]
    if nodata is not None and not math.isnan(nodata):
        if raw.dtype.kind == "f":
            heights[raw == raw.dtype.type(nodata)] = np.nan
        elif float(nodata).is_integer() and np.iinfo(raw.dtype).min <= nodata <= np.iinfo(raw.dtype).max:
            heights[raw == raw.dtype.type(nodata)] = np.nan
    flags = ds.mask_flag_enums[band - 1]
    if MaskFlags.per_dataset in flags or MaskFlags.alpha in flags:
        heights[ds.read_masks(band, window=window) == 0] = np.nan
    return heights
