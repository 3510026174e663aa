"""``tankcd info`` of a raw terrain, not classified: a DEM raster, a heightmap or a mesh.

Nothing is classified and nothing is written (no store, no cache, no temporary file): a raster is
read by its header (size, bands, type, NODATA, CRS, geotransform, block) and a bounded sample of
its posts; a heightmap likewise, with the options its file does not say; a mesh is read as replay
reads it (a mesh is read whole anyway) for its counts, bounds and parts.

The sample: a raster of at most ``EVERY_POST`` posts is read whole (its NODATA share and height
range exact); a larger one in ``SAMPLE_WINDOWS`` x ``SAMPLE_WINDOWS`` windows of at most
``WINDOW`` x ``WINDOW`` posts on a regular lattice, each window inside one of the file's blocks,
so the cost is at most that many blocks decoded whatever the raster's size (the NODATA share and
height range then are the sample's, and say so). The SHA-256 of a raster or heightmap is not
computed (it reads the whole file; classify records it in the store).
"""

from __future__ import annotations

import math
import os

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.heightmap import PNG_SUFFIXES, RAW_TYPES, heightmap_format
from tankcd_cli.io.rasters import crs_name, gdal_env, gdal_message, is_gdal_error, point_scale, quiet_warnings
from tankcd_cli.io.terrain_readers import read_terrain

EVERY_POST = 1 << 20
SAMPLE_WINDOWS = 16
WINDOW = 64


def _classify_hint(path: str, extra: str = "") -> str:
    """That the file is no store, and the command that makes one (where ``--cache`` keeps it)."""
    return (f"not classified: a raw terrain, not a store; tankcd classify {path}{extra} -o "
            f"{os.path.splitext(path)[0]}.h5 makes one (replay classifies it on the fly)")


def _lattice(n: int, block: int, size: int, count: int) -> list[tuple[int, int]]:
    """Up to ``count`` windows [a, b) of at most ``size`` along an axis of ``n`` posts, evenly
    spread, each inside one block of ``block`` posts."""
    size = max(1, min(size, block, n))
    out = []
    for k in range(count):
        centre = int((k + 0.5) * n / count)
        start = (centre // block) * block
        end = min(start + block, n)  # the last block may be short: the window keeps inside it
        a = max(start, min(centre - size // 2, end - size))
        out.append((a, min(a + size, end)))
    return sorted(set(out))


def sampled(read, rows: int, cols: int, block: tuple[int, int]) -> tuple[np.ndarray, bool]:
    """Heights read by ``read(r0, r1, c0, c1)`` (float64, NaN where missing): all of them for a
    small grid (True), else the lattice of windows (False), as one flat array."""
    if rows * cols <= EVERY_POST:
        return read(0, rows, 0, cols).ravel(), True
    bh, bw = (max(int(b), 1) for b in block)
    parts = [read(r0, r1, c0, c1).ravel()
             for r0, r1 in _lattice(rows, bh, WINDOW, SAMPLE_WINDOWS)
             for c0, c1 in _lattice(cols, bw, WINDOW, SAMPLE_WINDOWS)]
    return np.concatenate(parts), False


def _sample_facts(values: np.ndarray, every: bool, label: str = "extent_z") -> dict:
    finite = np.isfinite(values)
    n = int(values.size)
    out = {"sampled_posts": n, "every_post": every,
           "nodata_fraction": round(1.0 - int(finite.sum()) / n, 6) if n else 0.0,
           label: [float(values[finite].min()), float(values[finite].max())] if finite.any() else None}
    return out


# --- a DEM raster ---------------------------------------------------------------------------------

def describe_raster(path: str) -> dict:
    """A raster DEM GDAL reads (GeoTIFF, ESRI ASCII, DTED, HGT, ...), by its header and a sample."""
    import rasterio
    from rasterio.windows import Window

    with gdal_env(), quiet_warnings():
        try:
            ds = rasterio.open(path)
        except Exception as exc:
            if not is_gdal_error(exc):
                raise
            raise InputError(path, f"not a raster GDAL can read: {gdal_message(exc)}") from None
        with ds:
            try:
                return _raster_facts(path, ds, Window, crs_name)
            except InputError:
                raise
            except Exception as exc:
                if not is_gdal_error(exc):
                    raise
                raise InputError(path, f"damaged raster: {gdal_message(exc)}") from None


def _raster_facts(path, ds, Window, crs_name) -> dict:
    t = ds.transform
    georeferenced = not t.is_identity
    crs = ds.crs if georeferenced else None
    rows, cols = ds.height, ds.width
    facts = {"file": path, "kind": "DEM raster", "format": ds.driver, "store": _classify_hint(path)}
    if crs is not None:
        unit = "degree" if crs.is_geographic else crs.linear_units_factor[0]
        facts["crs"] = crs_name(crs)
        facts["crs_units"] = unit
    else:
        facts["crs"] = "local grid (no CRS)" if georeferenced else "local grid (no georeferencing; 1 m posts assumed)"
    facts["grid_posts"] = {"rows": rows, "columns": cols}
    facts["posts"] = rows * cols
    facts["bands"] = ds.count
    facts["heights"] = ds.dtypes[0]
    facts["nodata_value"] = None if ds.nodatavals[0] is None else float(ds.nodatavals[0])
    if georeferenced:
        if t.b or t.d:
            facts["geotransform"] = "rotated (terms b, d non-zero): classify needs it warped to north-up"
        dx, dy = float(t.a), float(-t.e)
        x0, y0 = float(t.c + 0.5 * t.a), float(t.f + 0.5 * t.e)
    else:
        dx, dy, x0, y0 = 1.0, 1.0, 0.0, float(rows - 1)
    facts["post_spacing"] = [dx, dy]
    facts["north_west_post"] = [x0, y0]
    xs, ys = sorted([x0, x0 + (cols - 1) * dx]), sorted([y0 - (rows - 1) * dy, y0])
    facts["extent_x"], facts["extent_y"] = xs, ys
    if crs is None or crs.is_projected:
        factor = 1.0 if crs is None else float(crs.linear_units_factor[1])
        facts["size_km"] = [round((xs[1] - xs[0]) * factor / 1000, 3), round((ys[1] - ys[0]) * factor / 1000, 3)]
    if crs is not None and crs.is_projected:
        facts["point_scale"] = _point_scale(crs, (xs[0], ys[0], xs[1], ys[1]))
    block = tuple(int(v) for v in ds.block_shapes[0])
    facts["tile_posts"] = {"rows": block[0], "columns": block[1]}
    if ds.count > 1:
        facts["band_read"] = f"1 of {ds.count} (classify needs --band N)"

    def read(r0, r1, c0, c1):
        a = ds.read(1, window=Window(c0, r0, c1 - c0, r1 - r0), masked=True)
        out = np.asarray(a.filled(np.nan) if a.dtype.kind == "f" else a.astype(np.float64).filled(np.nan),
                         dtype=np.float64)
        out[~np.isfinite(out)] = np.nan
        return out

    values, every = sampled(read, rows, cols, block)
    facts.update(_sample_facts(values, every))
    facts["file_bytes"] = os.path.getsize(path)
    return {k: v for k, v in facts.items() if v is not None or k in ("nodata_value", "extent_z")}


def _point_scale(crs, bounds: tuple[float, float, float, float]) -> dict | None:
    """A projected CRS's point scale over the posts' ``bounds`` (west, south, east, north; the
    reader's own ``io.rasters.point_scale``): ``centre`` (the square root of the areal scale at the
    centre), ``range`` (the least and greatest meridional or parallel scale at the centre, the
    corners and the edges' midpoints), ``ground_metres_per_crs_metre`` (1 / centre). 1 for a true
    metric grid; about 2 for Web Mercator at 60 deg. None where pyproj cannot say. The same
    figures a store records of its source (``source_point_scale``, docs/formats.md)."""
    scale = point_scale(crs, bounds)
    if scale is None:
        return None
    return {"centre": round(scale.centre, 6), "range": [round(scale.low, 6), round(scale.high, 6)],
            "ground_metres_per_crs_metre": round(1 / scale.centre, 6)}


# --- a heightmap ----------------------------------------------------------------------------------

HEIGHTMAP_NEEDS = {"spacing": "--spacing M (required: the file holds no post spacing)",
                   "heights": "--z-scale S and --z-offset O, or --z-range LOW HIGH (default: the values are metres)",
                   "placement": "--origin X Y (the north-west post; default: the south-west post at 0, 0) "
                                "and --crs (default: a local grid)"}


def describe_heightmap(path: str) -> dict:
    """A heightmap (PNG, RAW): its size, bits and channels, its values' range (a sample), and the
    options classify needs, which the file does not say."""
    kind = heightmap_format(path, None)
    facts = _png_facts(path) if kind in PNG_SUFFIXES else _raw_facts(path, kind)
    facts["options"] = dict(HEIGHTMAP_NEEDS)
    facts["file_bytes"] = os.path.getsize(path)
    return facts


def _png_facts(path: str) -> dict:
    import rasterio
    from rasterio.windows import Window

    with gdal_env(), quiet_warnings():
        try:
            ds = rasterio.open(path, driver="PNG")
        except Exception as exc:
            if not is_gdal_error(exc):
                raise
            raise InputError(path, f"not a PNG GDAL can read: {gdal_message(exc)}") from None
        with ds:
            interp = [c.name for c in ds.colorinterp]
            bits = int(ds.tags(1, ns="IMAGE_STRUCTURE").get("NBITS", np.dtype(ds.dtypes[0]).itemsize * 8))
            facts = {"file": path, "kind": "heightmap", "format": "PNG",
                     "store": _classify_hint(path, " --spacing M"),
                     "grid_posts": {"rows": ds.height, "columns": ds.width}, "posts": ds.height * ds.width,
                     "bits": bits, "channels": interp}
            if any(c in ("red", "green", "blue") for c in interp):
                facts["band_read"] = f"1 of {ds.count} (a colour PNG: classify needs --band N)"
            if "palette" in interp:
                facts["band_read"] = "a palette PNG: its values are colour indices, not heights (classify refuses it)"
            try:
                values, every = sampled(lambda r0, r1, c0, c1: ds.read(1, window=Window(c0, r0, c1 - c0, r1 - r0))
                                        .astype(np.float64), ds.height, ds.width, ds.block_shapes[0])
            except Exception as exc:
                if not is_gdal_error(exc):
                    raise
                raise InputError(path, f"damaged PNG: {gdal_message(exc)}") from None
    out = _sample_facts(values, every, "extent_value")
    out.pop("nodata_fraction")  # a heightmap has no NODATA
    facts.update(out)
    return facts


def _raw_facts(path: str, kind: str) -> dict:
    nbytes = os.path.getsize(path)
    if nbytes == 0:
        raise InputError(path, "file is empty")
    dtype = np.dtype(RAW_TYPES[kind])
    facts = {"file": path, "kind": "heightmap", "format": f"RAW (.{kind})",
             "store": _classify_hint(path, " --spacing M")}
    # as the RAW reader takes a file without --size: square, and a .raw 8-bit when only 8-bit posts fit
    types = [dtype] + ([np.dtype("u1")] if kind == "raw" else [])
    square = [(math.isqrt(nbytes // t.itemsize), t) for t in types if nbytes % t.itemsize == 0]
    square = [(n, t) for n, t in square if n >= 2 and n * n * t.itemsize == nbytes]
    if not square:
        facts.update(values=dtype.name, bits=dtype.itemsize * 8,
                     grid_posts=f"{nbytes:,} bytes: not a square of {dtype.itemsize * 8}-bit posts "
                                "(classify needs --size COLSxROWS)")
        return facts
    (cols, dtype), rows = square[0], square[0][0]
    facts.update(grid_posts={"rows": rows, "columns": cols}, posts=rows * cols,
                 grid_posts_from="the file's size, taken as a square (--size COLSxROWS says otherwise)",
                 values=np.dtype(dtype).name + (" little-endian" if dtype.itemsize > 1 else ""),
                 bits=dtype.itemsize * 8)

    def read(r0, r1, c0, c1):
        mapped = np.memmap(path, dtype=dtype, mode="r", offset=r0 * cols * dtype.itemsize, shape=(r1 - r0, cols))
        values = np.array(mapped[:, c0:c1], dtype=np.float64)
        del mapped
        values[~np.isfinite(values)] = np.nan
        return values

    values, every = sampled(read, rows, cols, (1, cols))
    out = _sample_facts(values, every, "extent_value")
    if dtype.kind != "f":
        out.pop("nodata_fraction")  # integer posts are all heights
    facts.update(out)
    return facts


# --- a mesh -----------------------------------------------------------------------------------------

def describe_mesh(path: str) -> dict:
    """A terrain mesh as replay reads it (``io.terrain_readers.read_terrain``): its format, the up
    axis applied, vertices and triangles, bounds, parts and what was left out."""
    raw = read_terrain(path)
    v = raw.vertices
    lo, hi = (v.min(axis=0), v.max(axis=0)) if len(v) else (np.zeros(3), np.zeros(3))
    facts = {"file": path, "kind": "terrain mesh", "format": raw.format, "store": _classify_hint(path),
             "sha256": raw.sha256, "up_applied": raw.up, "vertices": int(len(v)), "faces": int(len(raw.faces)),
             "extent_x": [float(lo[0]), float(hi[0])], "extent_y": [float(lo[1]), float(hi[1])],
             "extent_z": [float(lo[2]), float(hi[2])]}
    if raw.face_part is not None and raw.part_names:
        counts = np.bincount(raw.face_part, minlength=len(raw.part_names))
        facts["parts"] = {name: int(n) for name, n in zip(raw.part_names, counts)}
    facts["skipped"] = dict(raw.skipped)
    return facts
