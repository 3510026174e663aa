"""Raster DEM reader: one ground in every format reads the same; geographic tiles warp to UTM; bad input is one line."""

from __future__ import annotations

import hashlib
import io
import math
import os
import subprocess
import sys
import tracemalloc
import zipfile

import numpy as np
import pytest

rasterio = pytest.importorskip("rasterio")
# writing the bare raster warns that it has no geotransform: that is the point
pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")


def from_origin(west, north, dx, dy):
    """North-up geotransform from the outer north-west corner (rasterio's own multiplies affines with a deprecated '*')."""
    return Affine(dx, 0, west, 0, -dy, north)
from rasterio.crs import CRS  # noqa: E402
from rasterio.transform import Affine  # noqa: E402
from rasterio.warp import transform as warp_points, transform_bounds  # noqa: E402

from tankcd_cli.errors import InputError  # noqa: E402
from tankcd_cli.geometry.post_grid import PostGrid  # noqa: E402
from tankcd_cli.io.dem_source import DemSourceInfo  # noqa: E402
from tankcd_cli.io.rasters import RASTER_SUFFIXES, is_raster, open_raster  # noqa: E402
from tankcd_cli.io.esri_ascii import parse_esri_ascii  # noqa: E402

# --- one ground, many formats ---------------------------------------------------

ROWS, COLS, STEP = 150, 170, 2.0
WEST, NORTH = 500000.0, 5001000.0          # outer corner of post [0, 0]
NODATA = -9999
SPLIT_ROW, SPLIT_COL = 70, 90               # tile seams, off every block boundary


def ground() -> np.ndarray:
    """Integer heights (every format stores them exactly) with a NODATA hole."""
    rows, cols = np.mgrid[0:ROWS, 0:COLS]
    x = WEST + STEP * (cols + 0.5)
    y = NORTH - STEP * (rows + 0.5)
    z = np.round(100 + 5 * np.sin(x / 30) * np.cos(y / 40) + 3 * rows / ROWS).astype(np.int16)
    z[40:52, 60:75] = NODATA
    return z


def expected(r0, r1, c0, c1) -> np.ndarray:
    z = ground().astype(np.float64)
    z[z == NODATA] = np.nan
    out = np.full((r1 - r0, c1 - c0), np.nan)
    a0, a1, b0, b1 = max(r0, 0), min(r1, ROWS), max(c0, 0), min(c1, COLS)
    if a0 < a1 and b0 < b1:
        out[a0 - r0:a1 - r0, b0 - c0:b1 - c0] = z[a0:a1, b0:b1]
    return out


def profile(rows=ROWS, cols=COLS, west=WEST, north=NORTH, **extra):
    base = dict(width=cols, height=rows, crs="EPSG:32633",
                transform=from_origin(west, north, STEP, STEP), nodata=NODATA)
    base.update(extra)
    return base


def write(path, data, driver="GTiff", **kw):
    data = np.asarray(data)
    if data.ndim == 2:
        data = data[None]
    kw.setdefault("count", data.shape[0])
    kw.setdefault("height", data.shape[1])
    kw.setdefault("width", data.shape[2])
    kw.setdefault("dtype", str(data.dtype))
    with rasterio.open(path, "w", driver=driver, **kw) as dst:
        dst.write(data)
    return str(path)


def write_tiles(folder) -> list[str]:
    folder.mkdir(exist_ok=True)
    z = ground()
    names = []
    for i, (r0, r1) in enumerate(((0, SPLIT_ROW), (SPLIT_ROW, ROWS))):
        for j, (c0, c1) in enumerate(((0, SPLIT_COL), (SPLIT_COL, COLS))):
            name = f"tile_{i}{j}.tif"
            write(folder / name, z[r0:r1, c0:c1], **profile(r1 - r0, c1 - c0, WEST + c0 * STEP, NORTH - r0 * STEP))
            names.append(name)
    return names


def write_vrt(path, names):
    sources = []
    for name in names:
        with rasterio.open(path.parent / name) as ds:
            c0 = round((ds.transform.c - WEST) / STEP)
            r0 = round((NORTH - ds.transform.f) / STEP)
            sources.append(f"""  <ComplexSource>
      <SourceFilename relativeToVRT="1">{name}</SourceFilename><SourceBand>1</SourceBand>
      <SrcRect xOff="0" yOff="0" xSize="{ds.width}" ySize="{ds.height}"/>
      <DstRect xOff="{c0}" yOff="{r0}" xSize="{ds.width}" ySize="{ds.height}"/>
      <NODATA>{NODATA}</NODATA>
    </ComplexSource>""")
    srs = CRS.from_epsg(32633).to_wkt()
    path.write_text(f"""<VRTDataset rasterXSize="{COLS}" rasterYSize="{ROWS}">
  <SRS>{srs}</SRS>
  <GeoTransform>{WEST}, {STEP}, 0, {NORTH}, 0, {-STEP}</GeoTransform>
  <VRTRasterBand dataType="Int16" band="1">
    <NoDataValue>{NODATA}</NoDataValue>
{chr(10).join(sources)}
  </VRTRasterBand>
</VRTDataset>
""")
    return str(path)


@pytest.fixture(scope="module")
def same_ground(tmp_path_factory):
    d = tmp_path_factory.mktemp("ground")
    z = ground()
    paths = {
        "tiled": write(d / "tiled.tif", z, tiled=True, blockxsize=32, blockysize=32, **profile()),
        "striped": write(d / "striped.tif", z, blockysize=7, **profile()),
        "cog": write(d / "cog.tif", z, driver="COG", blocksize=64, **profile()),
        "asc": write(d / "ground.asc", z, driver="AAIGrid", **profile()),
    }
    names = write_tiles(d / "tiles")
    paths["vrt"] = write_vrt(d / "tiles" / "mosaic.vrt", names)  # inside the folder: the folder reader skips it
    paths["folder"] = str(d / "tiles")
    archive = d / "tiles.zip"
    with zipfile.ZipFile(archive, "w") as zf:
        for name in names:
            zf.write(d / "tiles" / name, name)
    paths["zip"] = str(archive)
    return paths


WINDOWS = [
    (0, ROWS, 0, COLS),                     # everything
    (-5, 10, -7, 12),                       # across the north-west corner
    (ROWS - 4, ROWS + 6, COLS - 3, COLS + 9),  # across the south-east corner
    (SPLIT_ROW - 3, SPLIT_ROW + 4, SPLIT_COL - 5, SPLIT_COL + 2),  # where four tiles meet
    (35, 60, 55, 80),                       # the NODATA hole
    (ROWS + 10, ROWS + 20, 0, 10),          # wholly south
    (-30, -20, -30, -20),                   # wholly north-west
    (-3, ROWS + 3, -2, COLS + 2),           # larger than the raster
    (5, 5, 3, 9),                           # empty
]


@pytest.mark.parametrize("kind", ["tiled", "striped", "cog", "asc", "vrt", "folder", "zip"])
def test_every_format_reads_the_same_ground(same_ground, kind):
    with open_raster(same_ground[kind]) as src:
        info, grid = src.info, src.grid
        assert (grid.rows, grid.cols) == (ROWS, COLS)
        assert grid.origin == (WEST + STEP / 2, NORTH - STEP / 2)
        assert grid.spacing == (STEP, STEP)
        assert CRS.from_wkt(grid.crs_wkt).to_epsg() == 32633
        assert "UTM zone 33N" in grid.crs_name.replace("_", " ").replace("Zone", "zone")
        assert not info.reprojected
        assert info.nodata == NODATA
        assert info.band == info.bands == 1
        assert info.block[0] >= 1 and info.block[1] >= 1
        for window in WINDOWS:
            got = src.read(*window)
            assert got.dtype == np.float64
            np.testing.assert_array_equal(got, expected(*window), err_msg=f"{kind} {window}")
    assert info.format == {"asc": "AAIGrid", "vrt": "VRT", "folder": "VRT", "zip": "VRT"}.get(kind, "GTiff")
    assert info.source == same_ground[kind]


def test_grid_info_fields_and_hashes(same_ground):
    with open_raster(same_ground["tiled"]) as src:
        info, grid = src.info, src.grid
    assert isinstance(info, DemSourceInfo) and isinstance(grid, PostGrid)
    assert info.block == (32, 32) and info.dtype == "int16" and info.height_dtype == "float32"
    with open(same_ground["tiled"], "rb") as fh:
        assert info.sha256 == hashlib.sha256(fh.read()).hexdigest()
    with open_raster(same_ground["striped"]) as src:
        assert src.info.block == (7, COLS)
    folder = same_ground["folder"]
    tiles = sorted(n for n in os.listdir(folder) if n.endswith(".tif"))

    def listing(names, base):
        lines = ""
        for name in sorted(names):
            with open(os.path.join(base, name), "rb") as fh:
                lines += f"{hashlib.sha256(fh.read()).hexdigest()}  {name}\n"
        return hashlib.sha256(lines.encode()).hexdigest()

    with open_raster(folder) as src:
        assert src.info.sha256 == listing(tiles, folder)
    with open_raster(same_ground["vrt"]) as src:  # the VRT text and every tile it names
        assert src.info.sha256 == listing(tiles + ["mosaic.vrt"], folder)


def test_closed_source_and_context(same_ground):
    src = open_raster(same_ground["tiled"])
    src.close()
    src.close()
    with pytest.raises(ValueError):
        src.read(0, 2, 0, 2)


def test_stdin_needs_format_and_reads_with_it(same_ground, monkeypatch):
    with pytest.raises(InputError, match="<stdin>.*--format"):
        open_raster("-")
    with open(same_ground["cog"], "rb") as fh:
        data = fh.read()
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))
    with open_raster("-", fmt="tif") as src:
        assert src.info.source == "<stdin>" and src.info.sha256 == hashlib.sha256(data).hexdigest()
        np.testing.assert_array_equal(src.read(30, 60, 50, 90), expected(30, 60, 50, 90))


def test_format_overrides_the_suffix(same_ground, tmp_path):
    odd = tmp_path / "ground.data"
    odd.write_bytes(open(same_ground["tiled"], "rb").read())
    with open_raster(str(odd), fmt="tif") as src:
        np.testing.assert_array_equal(src.read(0, 20, 0, 20), expected(0, 20, 0, 20))
    with open_raster(str(odd), fmt="GTiff") as src:
        assert src.info.format == "GTiff"
    with pytest.raises(InputError, match="ground.data.*DTED"):
        open_raster(str(odd), fmt="dt1")
    with pytest.raises(InputError, match="unknown raster format"):
        open_raster(str(odd), fmt="nonsense")


# --- ASCII grids keep every decimal -----------------------------------------------

def test_ascii_grid_decimals_are_float64_exact(tmp_path):
    rng = np.random.default_rng(7)
    values = rng.uniform(-50, 3000, size=(6, 9))
    tokens = [[f"{v:.12f}" for v in row] for row in values]
    tokens[2][3] = "-9999"
    text = ("ncols 9\nnrows 6\nxllcorner 1000.5\nyllcorner 2000.25\ncellsize 0.5\nNODATA_value -9999\n"
            + "\n".join(" ".join(row) for row in tokens) + "\n")
    path = tmp_path / "dec.asc"
    path.write_text(text)
    vertices, _, posts = parse_esri_ascii(text.encode(), str(path))
    theirs = np.full(posts.vertex.shape, np.nan)  # row 0 north, as the raster's
    theirs[posts.vertex >= 0] = vertices[posts.vertex[posts.vertex >= 0], 2]
    with open_raster(str(path)) as src:
        ours = src.read(0, 6, 0, 9)
        assert src.grid.origin == posts.geometry.origin
        assert src.grid.spacing == posts.geometry.spacing
        assert src.info.dtype == "float64" and src.info.height_dtype == "float64"
        assert src.grid.crs_wkt == "" and src.grid.crs_name == "local grid (no CRS)"
    np.testing.assert_array_equal(ours, theirs)
    assert ours[0, 0] == float(tokens[0][0]) and ours[5, 8] == float(tokens[5][8])


# --- geographic tiles: DTED, SRTM HGT ---------------------------------------------

LAT, LON = 45, 6


def tile_heights(rows, cols):
    r, c = np.mgrid[0:rows, 0:cols]
    return np.round(300 + 80 * np.sin(c / cols * 9) + 60 * np.cos(r / rows * 7)).astype(np.int16)


def write_geographic_tile(path, rows, cols, driver, lat=LAT, lon=LON):
    """A one-degree tile whose outermost posts sit on the whole degrees, as DTED and HGT cells do."""
    dy, dx = 1 / (rows - 1), 1 / (cols - 1)
    tmp = str(path) + ".src.tif"
    z = tile_heights(rows, cols)
    write(tmp, z, crs="EPSG:4326", transform=Affine(dx, 0, lon - dx / 2, 0, -dy, lat + 1 + dy / 2), nodata=-32767)
    rasterio.shutil.copy(tmp, str(path), driver=driver)
    os.unlink(tmp)
    for side in (str(path) + ".aux.xml",):
        if os.path.exists(side):
            os.unlink(side)
    return z


@pytest.fixture(scope="module")
def geo_tiles(tmp_path_factory):
    import rasterio.shutil  # noqa: F401

    d = tmp_path_factory.mktemp("geo")
    tiles = {}
    for level, n in ((0, 121), (1, 1201), (2, 3601)):
        path = d / f"n45e006.dt{level}"
        tiles[f"dt{level}"] = (str(path), write_geographic_tile(path, n, n, "DTED"))
    hgt = d / "N45E006.hgt"
    tiles["hgt"] = (str(hgt), write_geographic_tile(hgt, 1201, 1201, "SRTMHGT"))
    with zipfile.ZipFile(d / "N45E006.hgt.zip", "w", zipfile.ZIP_DEFLATED) as zf:
        zf.write(hgt, "N45E006.hgt")
    tiles["hgt.zip"] = (str(d / "N45E006.hgt.zip"), tiles["hgt"][1])  # the same heights as N45E006.hgt
    with zipfile.ZipFile(d / "download.zip", "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("README.txt", "not a raster")
        zf.write(hgt, "N45E006.hgt")
    tiles["zip"] = (str(d / "download.zip"), tiles["hgt"][1])
    return tiles


def source_bilinear(path, z, x, y, crs):
    """The source surface at metric point (x, y): bilinear between the four posts around it."""
    with rasterio.open(path) as ds:
        (lon,), (lat,) = warp_points(crs, "EPSG:4326", [x], [y])
        t = ds.transform
    col, row = (lon - t.c) / t.a - 0.5, (lat - t.f) / t.e - 0.5
    r0, c0 = int(math.floor(row)), int(math.floor(col))
    fr, fc = row - r0, col - c0
    q = z[r0:r0 + 2, c0:c0 + 2].astype(float)
    return q[0, 0] * (1 - fr) * (1 - fc) + q[0, 1] * (1 - fr) * fc + q[1, 0] * fr * (1 - fc) + q[1, 1] * fr * fc


@pytest.mark.parametrize("kind, fmt, step", [("dt0", "DTED", 926.0), ("dt1", "DTED", 92.6), ("dt2", "DTED", 30.9),
                                             ("hgt", "SRTMHGT", 92.6), ("hgt.zip", "SRTMHGT", 92.6),
                                             ("zip", "SRTMHGT", 92.6)])
def test_geographic_tiles_warp_to_their_utm_zone(geo_tiles, kind, fmt, step):
    path, z = geo_tiles[kind]
    plain = geo_tiles["hgt"][0] if "zip" in kind else path  # the source as rasterio opens it
    with open_raster(path) as src:
        info, grid = src.info, src.grid
        assert info.format == fmt and info.reprojected and info.dtype == "int16" and info.height_dtype == "float32"
        assert CRS.from_wkt(grid.crs_wkt).to_epsg() == 32632
        assert grid.crs_name == "WGS 84 / UTM zone 32N" and info.source_crs_name == "WGS 84"
        assert grid.spacing == (step, step)
        assert all(abs(o / step - round(o / step)) < 1e-9 for o in grid.origin)  # posts on the step's lattice
        west, north = grid.origin
        east, south = west + (grid.cols - 1) * step, north - (grid.rows - 1) * step
        # the grid holds the tile's whole footprint, and no side lies a post or more beyond it
        fx0, fy0, fx1, fy1 = transform_bounds("EPSG:4326", "EPSG:32632", LON, LAT, LON + 1, LAT + 1, densify_pts=101)
        assert west <= fx0 < west + step and east - step < fx1 <= east
        assert south <= fy0 < south + step and north - step < fy1 <= north
        xs, ys = warp_points("EPSG:4326", "EPSG:32632", [LON, LON + 1, LON, LON + 1], [LAT, LAT, LAT + 1, LAT + 1])
        assert all(west <= x <= east and south <= y <= north for x, y in zip(xs, ys))
        # the grid's corners lie outside the tile (NaN), the centre inside with the source's height
        assert np.isnan(src.read(0, 1, 0, 1)[0, 0]) and np.isnan(src.read(grid.rows - 1, grid.rows, 0, 1)[0, 0])
        for r, c in ((grid.rows // 2, grid.cols // 2), (grid.rows // 3, grid.cols // 2 + 5)):
            height = src.read(r, r + 1, c, c + 1)[0, 0]
            want = source_bilinear(plain, z, west + c * step, north - r * step, "EPSG:32632")
            assert abs(height - want) < 0.05, (r, c, height, want)
        # a row across the whole grid and beyond: NaN, then one run of heights, then NaN
        row = src.read(grid.rows // 2, grid.rows // 2 + 1, -10, grid.cols + 10)[0]
        assert row.shape == (grid.cols + 20,)
        finite = np.flatnonzero(np.isfinite(row))
        assert finite[0] > 10 and finite[-1] < grid.cols + 9 and len(finite) == finite[-1] - finite[0] + 1


def test_crs_option_names_the_utm_zone(geo_tiles):
    path, z = geo_tiles["dt0"]
    with open_raster(path, crs="EPSG:32631") as src:
        info, grid = src.info, src.grid
        assert CRS.from_wkt(grid.crs_wkt).to_epsg() == 32631 and grid.crs_name == "WGS 84 / UTM zone 31N"
        r, c = grid.rows // 2, grid.cols // 2
        x, y = grid.origin[0] + c * grid.spacing[0], grid.origin[1] - r * grid.spacing[1]
        assert abs(src.read(r, r + 1, c, c + 1)[0, 0] - source_bilinear(path, z, x, y, "EPSG:32631")) < 0.05


def test_projected_source_warps_only_when_asked(same_ground):
    with open_raster(same_ground["tiled"], crs="EPSG:32633") as src:  # its own CRS: nothing to do
        assert not src.info.reprojected
    with open_raster(same_ground["tiled"], crs="EPSG:32632") as src:
        info, grid = src.info, src.grid
        assert info.reprojected and grid.spacing == (2.0, 2.0) and CRS.from_wkt(grid.crs_wkt).to_epsg() == 32632
        assert info.source_crs_name == "WGS 84 / UTM zone 33N"
        block = src.read(grid.rows // 2 - 5, grid.rows // 2 + 5, grid.cols // 2 - 5, grid.cols // 2 + 5)
        assert np.isfinite(block).all() and 95 < block.mean() < 110


def test_feet_need_a_crs(tmp_path):
    path = write(tmp_path / "feet.tif", np.full((4, 5), 10, np.int16), crs="EPSG:2263",
                 transform=from_origin(980000, 200000, 2, 2))
    with pytest.raises(InputError, match=r"feet\.tif: CRS .* is in US survey foot; give --crs to reproject"):
        open_raster(path)
    with open_raster(path, crs="EPSG:32618") as src:
        assert src.info.reprojected and src.grid.spacing == (0.61, 0.61)


def test_dted_with_a_bad_checksum_fails_at_read(geo_tiles, tmp_path):
    path, _ = geo_tiles["dt0"]
    data = bytearray(open(path, "rb").read())
    record = 12 + 2 * 121  # DTED level 0: 121 posts a column, 8-byte header, 4-byte checksum
    data[3428 + 60 * record + 8 + 2 * 50] ^= 1  # a height in the middle column
    bad = tmp_path / "n45e006.dt0"
    bad.write_bytes(bytes(data))
    with open_raster(str(bad)) as src:  # the first and last columns are sound
        with pytest.raises(InputError) as caught:
            src.read(0, src.grid.rows, 0, src.grid.cols)
    text = str(caught.value)
    assert str(bad) in text and "checksum" in text and "\n" not in text and "rows 0-" in text


# --- memory: windows of a large raster ------------------------------------------------

def test_large_raster_read_window_by_window(tmp_path):
    n = 2000
    rows, cols = np.mgrid[0:n, 0:n]
    path = write(tmp_path / "big.tif", ((rows * 7 + cols * 3) % 20011).astype(np.int16), tiled=True,
                 blockxsize=256, blockysize=256, compress="deflate", **profile(n, n))
    del rows, cols
    with open_raster(path) as src:
        assert src.info.block == (256, 256)
        tracemalloc.start()
        try:
            for r0 in range(-100, n, 700):
                for c0 in range(-100, n, 700):
                    got = src.read(r0, r0 + 256, c0, c0 + 256)
                    rr, cc = np.mgrid[r0:r0 + 256, c0:c0 + 256]
                    want = np.where((rr >= 0) & (rr < n) & (cc >= 0) & (cc < n), (rr * 7 + cc * 3) % 20011, np.nan)
                    np.testing.assert_array_equal(got, want)
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
    assert peak < 4 * 2**20, peak  # a whole-raster float64 read would be 32 MB


# --- bad input: one line naming the file -------------------------------------------------

def one_line_error(path, **kw) -> str:
    with pytest.raises(InputError) as caught:
        with open_raster(path, **kw) as src:
            src.read(0, src.grid.rows, 0, src.grid.cols)
    text = str(caught.value)
    assert "\n" not in text and text.startswith(str(path) if path != "-" else "<stdin>"), text
    return text


def test_missing_empty_and_foreign_files(tmp_path):
    assert "no such file" in one_line_error(str(tmp_path / "none.tif"))
    (tmp_path / "empty.tif").write_bytes(b"")
    assert "not a raster GDAL can read" in one_line_error(str(tmp_path / "empty.tif"))
    (tmp_path / "text.tif").write_text("hello\n")
    assert "not a raster GDAL can read" in one_line_error(str(tmp_path / "text.tif"))
    (tmp_path / "text.zip").write_text("hello\n")
    assert "zip" in one_line_error(str(tmp_path / "text.zip"))
    with zipfile.ZipFile(tmp_path / "nothing.zip", "w") as zf:
        zf.writestr("a.txt", "x")
    assert "holds no raster" in one_line_error(str(tmp_path / "nothing.zip"))


def test_bands(tmp_path):
    data = np.stack([np.full((4, 5), v, np.float32) for v in (1, 2, 3)])
    path = write(tmp_path / "three.tif", data, crs="EPSG:32633", transform=from_origin(0, 10, 1, 1))
    text = one_line_error(path)
    assert "3 bands" in text and "--band" in text
    assert "out of range" in one_line_error(path, band=4)
    with open_raster(path, band=2) as src:
        assert src.info.band == 2 and src.info.bands == 3
        assert (src.read(0, 4, 0, 5) == 2).all()


def test_bad_georeferencing(tmp_path):
    z = np.full((4, 5), 1, np.int16)
    rotated = write(tmp_path / "rotated.tif", z, crs="EPSG:32633", transform=Affine(1, 0.2, 0, 0.1, -1, 10))
    assert "rotated geotransform (terms b, d non-zero)" in one_line_error(rotated)
    south_up = write(tmp_path / "south_up.tif", z, crs="EPSG:32633", transform=Affine(1, 0, 0, 0, 1, 10))
    assert "south-up" in one_line_error(south_up)
    polar = write(tmp_path / "polar.tif", z, crs="EPSG:4326", transform=from_origin(10, 87, 0.01, 0.01))
    text = one_line_error(polar)
    assert "--crs" in text and "EPSG:32661" in text
    assert "is not a CRS" in one_line_error(polar, crs="EPSG:nonsense")
    assert "not a projected CRS" in one_line_error(polar, crs="EPSG:4326")
    assert "US survey foot" in one_line_error(polar, crs="EPSG:2263")
    with open_raster(polar, crs="EPSG:32661") as src:
        assert src.info.reprojected and src.grid.crs_name.startswith("WGS 84 / UPS North")


def test_local_grids(tmp_path):
    z = np.arange(12, dtype=np.float32).reshape(3, 4)
    no_crs = write(tmp_path / "no_crs.tif", z, transform=from_origin(100, 50, 0.5, 0.25))
    with open_raster(no_crs) as src:
        assert src.grid.crs_wkt == "" and src.grid.crs_name == "local grid (no CRS)"
        assert src.grid.origin == (100.25, 49.875) and src.grid.spacing == (0.5, 0.25)
    assert "no CRS" in one_line_error(no_crs, crs="EPSG:32633")
    bare = write(tmp_path / "bare.tif", z)
    with open_raster(bare) as src:
        info, grid = src.info, src.grid
        assert grid.crs_wkt == "" and grid.crs_name == "local grid (no georeferencing; 1 m posts assumed)"
        assert grid.origin == (0.0, 2.0) and grid.spacing == (1.0, 1.0)
        np.testing.assert_array_equal(src.read(0, 3, 0, 4), z)  # first file row is north


def test_too_small(tmp_path):
    path = write(tmp_path / "row.tif", np.ones((1, 5), np.int16), **profile(1, 5))
    assert "needs at least 2 x 2 posts" in one_line_error(path)


def test_truncated_and_corrupt_geotiff(tmp_path):
    z = ground()
    path = write(tmp_path / "whole.tif", z, tiled=True, blockxsize=32, blockysize=32, compress="deflate", **profile())
    data = open(path, "rb").read()
    cut = tmp_path / "cut.tif"
    cut.write_bytes(data[:len(data) // 2])
    assert "damaged raster" in one_line_error(str(cut))
    (tmp_path / "head.tif").write_bytes(data[:100])
    assert "not a raster GDAL can read" in one_line_error(str(tmp_path / "head.tif"))
    with rasterio.open(path) as ds:  # a tile in the middle
        offset = int(ds.get_tag_item("BLOCK_OFFSET_2_2", "TIFF", bidx=1))
        size = int(ds.get_tag_item("BLOCK_SIZE_2_2", "TIFF", bidx=1))
    broken = bytearray(data)
    broken[offset:offset + size] = bytes(size)
    bad = tmp_path / "bad_tile.tif"
    bad.write_bytes(bytes(broken))
    with open_raster(str(bad)) as src:
        assert np.array_equal(src.read(0, 32, 0, 32), expected(0, 32, 0, 32), equal_nan=True)
        with pytest.raises(InputError) as caught:
            src.read(50, 90, 40, 80)
    text = str(caught.value)
    assert text.startswith(str(bad)) and "rows 50-90 cols 40-80" in text and "\n" not in text


def test_vrt_with_a_missing_tile(same_ground, tmp_path):
    folder = tmp_path / "t"
    names = write_tiles(folder)
    vrt = write_vrt(folder / "m.vrt", names)
    os.unlink(folder / names[2])
    assert f"missing file: {names[2]}" in one_line_error(vrt)
    (tmp_path / "junk.vrt").write_text("<VRTDataset")
    assert "not a valid VRT" in one_line_error(str(tmp_path / "junk.vrt"))


@pytest.mark.parametrize("odd, message", [
    (dict(crs="EPSG:32632"), "has CRS WGS 84 / UTM zone 32N"),
    (dict(transform=from_origin(WEST, NORTH - 200, 1.0, 1.0)), "has post spacing 1 x 1"),
    (dict(count=2), "has 2 bands"),
    (dict(transform=from_origin(WEST + 0.5, NORTH - 200, STEP, STEP)), "off the post lattice"),
])
def test_folder_with_an_odd_tile(tmp_path, odd, message):
    folder = tmp_path / "tiles"
    write_tiles(folder)
    spec = profile(10, 10, WEST, NORTH - 200)
    spec.update(odd)
    data = np.ones((spec.pop("count", 1), 10, 10), np.int16)
    write(folder / "zz_odd.tif", data, **spec)
    text = one_line_error(str(folder))
    assert "tile zz_odd.tif" in text and message in text


def test_empty_folder(tmp_path):
    (tmp_path / "notes.txt").write_text("x")
    assert "holds no raster tiles" in one_line_error(str(tmp_path))


def test_folder_of_geographic_tiles_warps_as_one(geo_tiles, tmp_path):
    path, z = geo_tiles["dt0"]
    folder = tmp_path / "cells"
    folder.mkdir()
    write_geographic_tile(folder / "n45e006.dt0", 121, 121, "DTED")
    write_geographic_tile(folder / "n45e007.dt0", 121, 121, "DTED", lon=7)
    with open_raster(str(folder)) as both, open_raster(path) as one:
        assert both.info.reprojected and CRS.from_wkt(both.grid.crs_wkt).to_epsg() == 32632
        assert both.grid.cols > one.grid.cols * 1.8 and both.grid.spacing == one.grid.spacing
        # same lattice: the west tile's posts come back unchanged from the mosaic
        dc = round((one.grid.origin[0] - both.grid.origin[0]) / one.grid.spacing[0])
        dr = round((both.grid.origin[1] - one.grid.origin[1]) / one.grid.spacing[1])
        r, c = one.grid.rows // 2, one.grid.cols // 2
        np.testing.assert_allclose(both.read(dr + r - 3, dr + r + 3, dc + c - 3, dc + c + 3),
                                   one.read(r - 3, r + 3, c - 3, c + 3), atol=0.02)  # warp approximations differ


# --- types, suffixes, laziness --------------------------------------------------------------

@pytest.mark.parametrize("dtype, height_dtype", [("int16", "float32"), ("uint16", "float32"), ("uint8", "float32"),
                                                 ("float32", "float32"), ("int32", "float64"), ("float64", "float64")])
def test_height_dtype(tmp_path, dtype, height_dtype):
    path = write(tmp_path / "h.tif", np.arange(20, dtype=dtype).reshape(4, 5), **profile(4, 5, nodata=None))
    with open_raster(path) as src:
        assert src.info.dtype == dtype and src.info.height_dtype == height_dtype and src.info.nodata is None


def test_float32_nodata_compared_in_its_own_type(tmp_path):
    z = np.full((3, 3), 5.0, np.float32)
    z[1, 1] = np.float32(-9999.9)
    path = write(tmp_path / "f.tif", z, **profile(3, 3, nodata=-9999.9))
    with open_raster(path) as src:
        assert np.isnan(src.read(0, 3, 0, 3)).sum() == 1


def test_is_raster(tmp_path, same_ground):
    for suffix in ("tif", "TIFF", "dt0", "dt1", "dt2", "hgt", "hgt.zip", "zip", "asc", "vrt", "img"):
        assert is_raster(str(tmp_path / f"x.{suffix}")), suffix
    assert "zip" in RASTER_SUFFIXES and "hgt.zip" in RASTER_SUFFIXES
    assert not is_raster("-") and not is_raster(str(tmp_path / "mesh.obj"))
    assert is_raster(same_ground["folder"]) and not is_raster(str(tmp_path))
    plain = tmp_path / "dem_without_suffix"
    plain.write_bytes(open(same_ground["tiled"], "rb").read())
    assert is_raster(str(plain))


def test_rasterio_is_imported_lazily():
    code = "import tankcd_cli.io.rasters, sys; assert 'rasterio' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


# --- projected CRSs whose metres are not ground metres ----------------------------

RAMP_SLOPE = 0.2                         # 11.3 deg, rising east
UTM_CENTRE = (500000.0, 6653000.0)       # EPSG:32633, about 15 E 60 N


def _ramp_height(e, n):
    """The ground, in UTM zone 33N metres: a plane rising east."""
    return 100.0 + RAMP_SLOPE * (e - UTM_CENTRE[0]) + 0.0 * n


def _write_ramps(tmp_path):
    """(the ramp in EPSG:3857, the same ground in EPSG:32633): about 160 m square, ~1 m posts."""
    from pyproj import Transformer

    e0, n0 = UTM_CENTRE
    utm = write(tmp_path / "ramp_utm.tif", np.zeros((1, 161, 161)), crs="EPSG:32633", dtype="float64",
                transform=from_origin(e0 - 80.5, n0 + 80.5, 1.0, 1.0))
    rows, cols = np.mgrid[0:161, 0:161]
    with rasterio.open(utm, "r+") as ds:
        ds.write(_ramp_height(e0 - 80 + cols * 1.0, n0 + 80 - rows * 1.0)[None])
    to_merc = Transformer.from_crs("EPSG:32633", "EPSG:3857", always_xy=True)
    mx, my = to_merc.transform(e0, n0)
    step = 2.0                                  # ~1 ground metre at 60 N
    half = 90                                   # posts either side of the centre: ~90 m of ground
    x = mx + step * np.arange(-half, half + 1)
    y = my + step * np.arange(half, -half - 1, -1)
    xx, yy = np.meshgrid(x, y)
    ee, nn = Transformer.from_crs("EPSG:3857", "EPSG:32633", always_xy=True).transform(xx, yy)
    merc = write(tmp_path / "ramp_3857.tif", _ramp_height(ee, nn)[None], crs="EPSG:3857", dtype="float64",
                 transform=from_origin(x[0] - step / 2, y[0] + step / 2, step, step))
    return merc, utm


def test_web_mercator_is_reprojected_to_utm_with_a_warning(tmp_path):
    from tankcd_cli.errors import SetupWarning

    merc, _ = _write_ramps(tmp_path)
    with pytest.warns(SetupWarning, match=r"EPSG:3857 metres are 0\.50 ground metres here \(point scale 2\.00 "
                                          r"at the centre\): reprojected to EPSG:32633") as caught:
        src = open_raster(merc)
    assert len([w for w in caught if issubclass(w.category, SetupWarning)]) == 1
    with src:
        assert src.info.reprojected and src.grid.crs_name == "WGS 84 / UTM zone 33N"
        assert src.grid.dx == src.grid.dy == 1.0      # 2 m of EPSG:3857 at 60 N: 1 ground metre
        assert src.info.source_point_scale == pytest.approx(2.0, rel=2e-3)
        low, high = src.info.source_point_scale_range
        assert 1.99 < low < src.info.source_point_scale < high < 2.01
        # heights on the UTM lattice are the ramp's (bilinear between exact posts of a plane)
        z = src.read(20, src.grid.rows - 20, 20, src.grid.cols - 20)
        cols = np.arange(20, src.grid.cols - 20)
        e = src.grid.origin_x + cols * src.grid.dx
        np.testing.assert_allclose(z, np.broadcast_to(_ramp_height(e, 0.0), z.shape), atol=2e-3)


def test_crs_option_picks_the_target_of_a_scaled_crs(tmp_path):
    merc, _ = _write_ramps(tmp_path)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the user chose: no warning
        with open_raster(merc, crs="EPSG:32632") as src:
            assert src.grid.crs_name == "WGS 84 / UTM zone 32N" and src.info.reprojected
            assert src.grid.dx == pytest.approx(1.0, abs=0.01)  # ground metres, not EPSG:3857's


def test_crs_option_naming_a_scaled_crs_keeps_it_with_a_warning(tmp_path):
    from tankcd_cli.errors import SetupWarning

    merc, utm = _write_ramps(tmp_path)
    for path in (merc, utm):  # kept as it is, or warped to it: either way its metres are half a ground metre
        with pytest.warns(SetupWarning, match=r"--crs EPSG:3857: its metres are 0\.50 ground metres here \(point "
                                              r"scale 2\.00 at the centre\): kept as asked"):
            with open_raster(path, crs="EPSG:3857") as src:
                assert src.grid.crs_name == "WGS 84 / Pseudo-Mercator"


def test_a_crs_within_one_percent_is_kept(tmp_path):
    import warnings

    _, utm = _write_ramps(tmp_path)
    # and the edge of a UTM zone (scale 1.0004 at 3 deg off the central meridian): kept
    edge = write(tmp_path / "edge.tif", np.zeros((1, 20, 20), dtype=np.float32), crs="EPSG:32633",
                 transform=from_origin(670000.0, 6653000.0, 5.0, 5.0))
    for path in (utm, edge):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with open_raster(path) as src:
                assert not src.info.reprojected and src.grid.crs_name == "WGS 84 / UTM zone 33N"
                assert abs(src.info.source_point_scale - 1) < 0.01


def test_a_tank_on_a_web_mercator_ramp_pitches_as_on_utm(tmp_path):
    """The issue's case: an 11.3 deg ramp in EPSG:3857 at 60 N; before, a tank pitched 5.7 deg on it,
    and two tanks whose hulls overlap by 0.46 m on the ground did not touch."""
    import warnings

    from pyproj import Transformer

    from tankcd_cli import api
    from tankcd_cli.errors import SetupWarning
    from tankcd_cli.describe import describe_store as describe

    merc, utm = _write_ramps(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SetupWarning)
        api.classify(merc, str(tmp_path / "merc.h5"))
        api.classify(utm, str(tmp_path / "utm.h5"))
    e0, n0 = UTM_CENTRE
    pitch = {}
    for name in ("merc", "utm"):
        pose = api.place(str(tmp_path / f"{name}.h5"), [e0], [n0], [0.0], matcher="reference")
        pitch[name] = float(pose["pitch_deg"][0])
    assert abs(pitch["utm"]) == pytest.approx(math.degrees(math.atan(RAMP_SLOPE)), abs=0.05)
    assert pitch["merc"] == pytest.approx(pitch["utm"], abs=0.05)
    auto = api.place(str(tmp_path / "merc.h5"), [e0], [n0], [30.0])  # the default matcher, within its 0.5 deg
    assert float(auto["pitch_deg"][0]) ** 2 + float(auto["roll_deg"][0]) ** 2 == pytest.approx(
        math.degrees(math.atan(RAMP_SLOPE)) ** 2, abs=2 * 11.3 * 0.5)
    facts = describe(str(tmp_path / "merc.h5"))
    assert facts["reprojected_from"] == "WGS 84 / Pseudo-Mercator"
    assert facts["source_point_scale"]["centre"] == pytest.approx(2.0, rel=2e-3)
    assert describe(str(tmp_path / "utm.h5"))["source_point_scale"]["centre"] == pytest.approx(0.9996, abs=1e-6)

    # two tanks heading north, hulls (3.46 m wide) overlapping by 0.46 m on the ground
    to_geo = Transformer.from_crs("EPSG:32633", "EPSG:4326", always_xy=True)
    lon, lat = to_geo.transform([e0 - 1.5, e0 + 1.5], [n0, n0])
    rows = ["t,entity,lon,lat,heading_deg"] + [f"{t},{who},{lon[i]!r},{lat[i]!r},0"
                                               for t in (0, 1) for i, who in enumerate("AB")]
    track = tmp_path / "pair.csv"
    track.write_text("\n".join(rows) + "\n")
    for name in ("merc", "utm"):
        _, events = api.replay(str(track), terrain=str(tmp_path / f"{name}.h5"))
        assert [e for e in events if e["kind"] == "vehicle"], name


def test_a_scene_names_the_crs_a_raster_is_reprojected_to(tmp_path):
    """replay has no --crs: a scene's [terrain] crs (and band) apply to a DEM raster as classify's
    --crs does; on a store it is bad input naming the key."""
    import warnings

    from tankcd_cli import api
    from tankcd_cli.errors import SetupWarning
    from tankcd_cli.scene import load_scene

    merc, _ = _write_ramps(tmp_path)
    (tmp_path / "scene.toml").write_text(f'[terrain]\npath = "{os.path.basename(merc)}"\ncrs = "EPSG:32632"\n')
    with warnings.catch_warnings():
        warnings.simplefilter("error", SetupWarning)  # the scene chose: no warning
        world = api.load_world(scene=str(tmp_path / "scene.toml"))
    assert world.terrain.surface.grid.crs_name == "WGS 84 / UTM zone 32N"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SetupWarning)
        api.classify(merc, str(tmp_path / "merc.h5"))
    (tmp_path / "store.toml").write_text('[terrain]\npath = "merc.h5"\ncrs = "EPSG:32632"\n')
    with pytest.raises(InputError, match=r"\[terrain\] crs: crs applies to a DEM raster"):
        load_scene(str(tmp_path / "store.toml"))
