"""What ``info`` says of a raw terrain, never classifying it: a GeoTIFF (its grid, CRS and point
scale against closed forms, its NODATA share counted), a large raster by a bounded sample (fast,
small, nothing written), a PNG and a RAW heightmap, a mesh."""

import math
import os
import time
import tracemalloc
import warnings

import numpy as np
import pytest

from tankcd_cli.describe import describe_store
from tankcd_cli.describe_terrain import EVERY_POST, SAMPLE_WINDOWS, WINDOW, _lattice
from tankcd_cli.errors import InputError

rasterio = pytest.importorskip("rasterio")
from rasterio.transform import from_origin  # noqa: E402


def write_tif(path, z, crs, x0, y0, dx, dy=None, nodata=None, **extra):
    """A GeoTIFF of z (row 0 north) whose north-west pixel's corner is (x0, y0)."""
    z = np.asarray(z)
    with rasterio.open(path, "w", driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype=z.dtype,
                       crs=crs, transform=from_origin(x0, y0, dx, dy or dx), nodata=nodata, **extra) as dst:
        dst.write(z, 1)
    return path


def test_a_geotiff_says_its_grid_crs_and_nodata_share(tmp_path):
    z = np.linspace(100.0, 140.0, 40 * 50).reshape(40, 50).astype("float32")
    z[:5, :8] = -9999.0  # 40 posts without data
    path = write_tif(tmp_path / "utm.tif", z, "EPSG:32633", 500_000.0, 4_500_000.0, 2.0, nodata=-9999.0)
    before = sorted(os.listdir(tmp_path))
    facts = describe_store(str(path))
    assert sorted(os.listdir(tmp_path)) == before  # no store, no cache beside it
    assert facts["kind"] == "DEM raster" and facts["format"] == "GTiff"
    assert f"tankcd classify {path} -o {tmp_path / 'utm.h5'}" in facts["store"]
    assert facts["crs"] == "WGS 84 / UTM zone 33N" and facts["crs_units"] == "metre"
    assert facts["grid_posts"] == {"rows": 40, "columns": 50} and facts["posts"] == 2000
    assert facts["post_spacing"] == [2.0, 2.0]
    assert facts["north_west_post"] == [500_001.0, 4_499_999.0]  # the pixel's centre
    assert facts["extent_x"] == [500_001.0, 500_001.0 + 49 * 2]
    assert facts["extent_y"] == [4_499_999.0 - 39 * 2, 4_499_999.0]
    assert facts["every_post"] and facts["sampled_posts"] == 2000
    assert facts["nodata_fraction"] == 40 / 2000 and facts["nodata_value"] == -9999.0
    valid = z[z != -9999.0]
    assert facts["extent_z"] == [float(valid.min()), float(valid.max())]
    # on the zone's central meridian (x = 500 km) a transverse Mercator's scale is its k0, 0.9996, and
    # k0 (1 + (dx / R)^2 / 2) a little off it: 98 m east, within 1e-9
    scale = facts["point_scale"]
    assert scale["centre"] == pytest.approx(0.9996, abs=1e-6)
    assert scale["range"] == pytest.approx([0.9996] * 2, abs=1e-6)
    assert scale["ground_metres_per_crs_metre"] == pytest.approx(1 / 0.9996, abs=1e-6)


def test_web_mercator_says_its_point_scale(tmp_path):
    lat = 60.0
    y = 6378137.0 * math.log(math.tan(math.pi / 4 + math.radians(lat) / 2))  # spherical Mercator northing of 60 N
    z = np.full((20, 20), 50.0, dtype="float32")
    path = write_tif(tmp_path / "web.tif", z, "EPSG:3857", 1_000_000.0, y + 10 * 30.0 + 15.0, 30.0)
    facts = describe_store(str(path))
    scale = facts["point_scale"]  # Mercator's scale is 1 / cos(latitude): two CRS metres a ground metre at 60 N
    assert scale["centre"] == pytest.approx(1 / math.cos(math.radians(lat)), rel=1e-3)
    # over the extent it runs from the south edge's secant to the north edge's (the sphere's inverse Mercator)
    ys = facts["extent_y"]
    secant = [1 / math.cos(2 * math.atan(math.exp(v / 6378137.0)) - math.pi / 2) for v in ys]
    assert scale["range"] == pytest.approx(secant, abs=2e-6)


def test_a_geographic_raster_keeps_its_degrees(tmp_path):
    z = np.zeros((30, 30), dtype="int16")
    facts = describe_store(str(write_tif(tmp_path / "geo.tif", z, "EPSG:4326", 6.0, 46.0, 1 / 3600)))
    assert facts["crs"] == "WGS 84" and facts["crs_units"] == "degree"
    assert facts["post_spacing"] == pytest.approx([1 / 3600, 1 / 3600])
    assert "size_km" not in facts and "point_scale" not in facts
    assert facts["nodata_value"] is None and facts["nodata_fraction"] == 0.0


def test_a_large_raster_is_described_by_a_bounded_sample_quickly_and_nothing_is_written(tmp_path, monkeypatch):
    """40,000 x 40,000 posts (6.4 GB as float32 if read): a tiled, sparse GeoTIFF of which a few
    tiles are written; info reads a lattice of windows, each inside one tile."""
    rows = cols = 40_000
    path = tmp_path / "big.tif"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(path, "w", driver="GTiff", width=cols, height=rows, count=1, dtype="float32",
                           crs="EPSG:32633", transform=from_origin(500_000.0, 4_600_000.0, 1.0, 1.0), nodata=-9999.0,
                           tiled=True, blockxsize=256, blockysize=256, sparse_ok=True, compress="deflate") as dst:
            from rasterio.windows import Window

            dst.write(np.full((256, 256), 123.0, dtype="float32"), 1, window=Window(0, 0, 256, 256))
    assert os.path.getsize(path) < 2 << 20
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    before = sorted(os.listdir(tmp_path))
    tracemalloc.start()
    start = time.perf_counter()
    try:
        facts = describe_store(str(path))
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert sorted(os.listdir(tmp_path)) == before and os.listdir(tmp) == []
    assert seconds < 5.0  # reading every post takes minutes and 6.4 GB
    assert peak < 64 << 20
    assert facts["grid_posts"] == {"rows": rows, "columns": cols}
    assert facts["tile_posts"] == {"rows": 256, "columns": 256}
    assert not facts["every_post"] and facts["sampled_posts"] <= SAMPLE_WINDOWS ** 2 * WINDOW ** 2
    assert facts["nodata_fraction"] == 1.0  # the lattice misses the one tile written: all NODATA
    assert facts["extent_z"] is None


def test_the_sample_lattice_keeps_each_window_in_one_block():
    for n, block in ((40_000, 256), (10_000, 1), (5_000, 5_000), (2_000, 300), (70, 64)):
        windows = _lattice(n, block, WINDOW, SAMPLE_WINDOWS)
        assert windows and all(0 <= a < b <= n for a, b in windows)
        assert all(a // block == (b - 1) // block for a, b in windows)
        assert all(b - a <= min(WINDOW, block, n) for a, b in windows)
        assert sum(b - a == min(WINDOW, block, n) for a, b in windows) >= len(windows) - 1  # a short last block
    assert EVERY_POST >= 1000 * 1000


def test_a_png_heightmap_says_its_size_values_and_the_options_it_needs(tmp_path):
    values = (np.arange(20 * 30).reshape(20, 30) * 100).astype("uint16")
    path = tmp_path / "hm.png"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(path, "w", driver="PNG", width=30, height=20, count=1, dtype="uint16") as dst:
            dst.write(values, 1)
    before = sorted(os.listdir(tmp_path))
    facts = describe_store(str(path))
    assert sorted(os.listdir(tmp_path)) == before
    assert facts["kind"] == "heightmap" and facts["format"] == "PNG" and facts["bits"] == 16
    assert facts["grid_posts"] == {"rows": 20, "columns": 30} and facts["channels"] == ["gray"]
    assert facts["extent_value"] == [0.0, float(values.max())] and facts["every_post"]
    assert "--spacing" in facts["options"]["spacing"] and "--spacing M" in facts["store"]


def test_a_raw_heightmap_square_or_not(tmp_path):
    values = np.arange(33 * 33, dtype="<u2").reshape(33, 33)
    (tmp_path / "hm.r16").write_bytes(values.tobytes())
    facts = describe_store(str(tmp_path / "hm.r16"))
    assert facts["format"] == "RAW (.r16)" and facts["bits"] == 16
    assert facts["grid_posts"] == {"rows": 33, "columns": 33}
    assert facts["extent_value"] == [0.0, float(33 * 33 - 1)] and "nodata_fraction" not in facts
    (tmp_path / "odd.r16").write_bytes(np.zeros(6 * 4, dtype="<u2").tobytes())
    facts = describe_store(str(tmp_path / "odd.r16"))
    assert "--size COLSxROWS" in facts["grid_posts"] and "extent_value" not in facts
    (tmp_path / "bytes.raw").write_bytes(bytes(range(9)))  # 9 bytes: only 3 x 3 8-bit posts fit, as the reader says
    facts = describe_store(str(tmp_path / "bytes.raw"))
    assert facts["grid_posts"] == {"rows": 3, "columns": 3} and facts["bits"] == 8 and facts["extent_value"] == [0, 8]


def test_a_mesh_says_its_counts_bounds_and_parts(tmp_path):
    lines = ["o ridge", "v 0 0 1", "v 10 0 2", "v 10 5 3", "v 0 5 1.5", "f 1 2 3", "f 1 3 4",
             "o gully", "v 20 0 -1", "v 30 0 -2", "v 30 5 -1", "f 5 6 7"]
    (tmp_path / "ground.obj").write_text("\n".join(lines) + "\n")
    before = sorted(os.listdir(tmp_path))
    facts = describe_store(str(tmp_path / "ground.obj"))
    assert sorted(os.listdir(tmp_path)) == before
    assert facts["kind"] == "terrain mesh" and facts["format"] == "obj" and facts["up_applied"] == "z"
    assert facts["vertices"] == 7 and facts["faces"] == 3
    assert facts["extent_x"] == [0.0, 30.0] and facts["extent_y"] == [0.0, 5.0] and facts["extent_z"] == [-2.0, 3.0]
    assert facts["parts"] == {"ridge": 2, "gully": 1} and len(facts["sha256"]) == 64


def test_a_gltf_is_a_mesh_though_it_is_json(tmp_path):
    import trimesh

    mesh = trimesh.Trimesh(vertices=[[0, 0, 0], [4, 0, 0], [0, 0, -3]], faces=[[0, 1, 2]])  # y-up: z -> -y
    trimesh.Scene(mesh).export(str(tmp_path / "ground.gltf"), file_type="gltf", embed_buffers=True)
    assert (tmp_path / "ground.gltf").read_bytes().lstrip().startswith(b"{")
    facts = describe_store(str(tmp_path / "ground.gltf"))
    assert facts["kind"] == "terrain mesh" and facts["up_applied"] == "y" and facts["faces"] == 1
    assert facts["extent_y"] == pytest.approx([0.0, 3.0])  # y-up turned z-up: the file's -z is north


def test_a_damaged_raster_is_one_line(tmp_path):
    (tmp_path / "cut.tif").write_bytes(b"II*\x00" + b"\x00" * 12)
    with pytest.raises(InputError, match="cut.tif: not a raster GDAL can read"):
        describe_store(str(tmp_path / "cut.tif"))


def test_an_xml_raster_is_a_dem_not_a_gpx_track(tmp_path):
    """A VRT is XML, which the trajectory reader takes for GPX by its first byte: the terrain readers'
    own magic (<VRTDataset) decides first, with the suffix or without it."""
    write_tif(tmp_path / "tile.tif", np.full((10, 12), 7.0, dtype="float32"), "EPSG:32633", 500_000.0, 4_500_000.0, 5.0)
    vrt = ('<VRTDataset rasterXSize="12" rasterYSize="10"><SRS>EPSG:32633</SRS>'
           '<GeoTransform>500000, 5, 0, 4500000, 0, -5</GeoTransform><VRTRasterBand dataType="Float32" band="1">'
           '<SimpleSource><SourceFilename relativeToVRT="1">tile.tif</SourceFilename><SourceBand>1</SourceBand>'
           '</SimpleSource></VRTRasterBand></VRTDataset>\n')
    for name in ("mosaic.vrt", "mosaic"):
        (tmp_path / name).write_text(vrt)
        facts = describe_store(str(tmp_path / name))
        assert facts["kind"] == "DEM raster" and facts["format"] == "VRT" and facts["extent_z"] == [7.0, 7.0]
