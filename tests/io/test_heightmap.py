"""Heightmaps as engines write them (io.heightmap): PNG through GDAL, RAW by memory map; the
grid they make (row 0 north, the north-west post at --origin, the south-west one at 0, 0 by
default), their heights (offset + scale x value, or a height range), and the files refused."""

import os
import warnings

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.heightmap import SPACING_NEEDED, HeightmapSpec, is_heightmap, open_heightmap, parse_size

rasterio = pytest.importorskip("rasterio")


def write_png(path, bands, dtype="uint16", **extra):
    """A PNG of (rows, cols) or (bands, rows, cols) values."""
    bands = np.asarray(bands, dtype=dtype)
    if bands.ndim == 2:
        bands = bands[None]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # not georeferenced: as engines write them
        with rasterio.open(path, "w", driver="PNG", width=bands.shape[2], height=bands.shape[1], count=bands.shape[0],
                           dtype=dtype, **extra) as dst:
            dst.write(bands)
    return path


def values(rows=20, cols=30, top=65535):
    r, c = np.mgrid[0:rows, 0:cols]
    return ((r * 977 + c * 131) % (top + 1)).astype(np.int64)


@pytest.mark.parametrize("dtype,top", [("uint16", 65535), ("uint8", 255)])
def test_a_grey_png_is_read_row_0_north_with_its_heights(tmp_path, dtype, top):
    v = values(top=top)
    path = write_png(tmp_path / "h.png", v, dtype)
    with open_heightmap(str(path), HeightmapSpec(spacing=2.0, z_scale=0.5, z_offset=-10.0)) as hm:
        g = hm.grid
        assert (g.rows, g.cols, g.dx, g.dy) == (20, 30, 2.0, 2.0)
        assert g.south_west == (0.0, 0.0) and g.origin == (0.0, 38.0)  # the default: south-west post at 0, 0
        np.testing.assert_array_equal(hm.read(0, 20, 0, 30), -10.0 + 0.5 * v)  # row 0 the image's top
        window = hm.read(-2, 3, 28, 33)  # past the edges: NaN there
        assert np.isnan(window[:2]).all() and np.isnan(window[:, 2:]).all()
        np.testing.assert_array_equal(window[2:, :2], -10.0 + 0.5 * v[:3, 28:30])
        assert hm.info.format == "PNG" and hm.info.dtype == dtype and hm.info.height_dtype == "float64"


def test_the_height_range_maps_the_full_scale(tmp_path):
    for dtype, top in (("uint16", 65535), ("uint8", 255)):
        v = values(top=top)
        v[0, 0], v[0, 1] = 0, top
        path = write_png(tmp_path / f"{dtype}.png", v, dtype)
        with open_heightmap(str(path), HeightmapSpec(spacing=1.0, z_range=(100.0, 150.0))) as hm:
            z = hm.read(0, 1, 0, 2)[0]
            assert z[0] == 100.0 and abs(z[1] - 150.0) < 1e-9
            assert hm.scale == pytest.approx(50.0 / top)


def test_origin_and_crs_place_the_north_west_post(tmp_path):
    path = write_png(tmp_path / "h.png", values())
    spec = HeightmapSpec(spacing=2.0, origin=(500000.0, 4500038.0), crs="EPSG:32633")
    with open_heightmap(str(path), spec) as hm:
        assert hm.grid.origin == (500000.0, 4500038.0) and hm.grid.south_west == (500000.0, 4500000.0)
        assert "UTM zone 33N" in hm.grid.crs_name and hm.grid.crs_wkt
    with pytest.raises(InputError, match="not a projected CRS"):
        open_heightmap(str(path), HeightmapSpec(spacing=2.0, crs="EPSG:4326"))


def test_alpha_is_ignored_and_said(tmp_path):
    v = values(top=255)
    alpha = np.full_like(v, 255)
    alpha[:5] = 0  # transparent rows: still heights
    path = write_png(tmp_path / "ga.png", np.stack([v, alpha]), "uint8")
    with open_heightmap(str(path), HeightmapSpec(spacing=1.0)) as hm:
        np.testing.assert_array_equal(hm.read(0, 20, 0, 30), v)
        assert any("alpha channel ignored" in n for n in hm.info.notes)


def test_colour_needs_a_band_and_a_palette_is_refused(tmp_path):
    rgb = np.stack([values(top=255), values(top=255) // 2, np.zeros((20, 30), int)])
    path = write_png(tmp_path / "rgb.png", rgb, "uint8")
    with pytest.raises(InputError) as err:
        open_heightmap(str(path), HeightmapSpec(spacing=1.0))
    assert "has colour channels" in str(err.value) and "--band N" in str(err.value)
    with open_heightmap(str(path), HeightmapSpec(spacing=1.0), band=2) as hm:
        np.testing.assert_array_equal(hm.read(0, 20, 0, 30), rgb[1])
    with open_heightmap(str(path), HeightmapSpec(spacing=1.0, band=2)) as hm:  # a scene's band
        np.testing.assert_array_equal(hm.read(0, 20, 0, 30), rgb[1])
    with pytest.raises(InputError, match="out of range"):
        open_heightmap(str(path), HeightmapSpec(spacing=1.0), band=4)
    pal = tmp_path / "pal.png"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(pal, "w", driver="PNG", width=4, height=4, count=1, dtype="uint8") as dst:
            dst.write(np.zeros((1, 4, 4), np.uint8))
            dst.write_colormap(1, {0: (255, 0, 0, 255), 1: (0, 0, 255, 255)})
    with pytest.raises(InputError, match="palette"):
        open_heightmap(str(pal), HeightmapSpec(spacing=1.0))


@pytest.mark.parametrize("suffix,dtype", [("r16", "<u2"), ("raw", "<u2"), ("r32", "<f4"), ("r8", "u1")])
def test_raw_is_read_square_or_by_size(tmp_path, suffix, dtype):
    v = values(rows=16, cols=16, top=255).astype(dtype)
    path = tmp_path / f"h.{suffix}"
    v.tofile(path)
    with open_heightmap(str(path), HeightmapSpec(spacing=0.5)) as hm:
        assert (hm.grid.rows, hm.grid.cols) == (16, 16)
        np.testing.assert_array_equal(hm.read(0, 16, 0, 16), v.astype(float))
        np.testing.assert_array_equal(hm.read(5, 9, 3, 20)[:, :13], v[5:9, 3:16].astype(float))
    w = values(rows=6, cols=10, top=255).astype(dtype)
    w.tofile(path)
    with open_heightmap(str(path), HeightmapSpec(spacing=0.5, size=(10, 6))) as hm:
        np.testing.assert_array_equal(hm.read(0, 6, 0, 10), w.astype(float))


def test_a_raw_of_8_bit_size_is_8_bit_and_float_nan_is_missing(tmp_path):
    v = values(rows=15, cols=15, top=255).astype("u1")  # 225 bytes: no square of 16-bit posts
    v.tofile(tmp_path / "h.raw")
    with open_heightmap(str(tmp_path / "h.raw"), HeightmapSpec(spacing=1.0)) as hm:
        assert hm.info.dtype == "uint8"
        np.testing.assert_array_equal(hm.read(0, 15, 0, 15), v)
    f = np.ones((4, 4), "<f4")
    f[1, 2] = np.nan
    f.tofile(tmp_path / "h.r32")
    with open_heightmap(str(tmp_path / "h.r32"), HeightmapSpec(spacing=1.0)) as hm:
        assert np.isnan(hm.read(0, 4, 0, 4)[1, 2]) and hm.info.height_dtype == "float32"
    with pytest.raises(InputError, match="float32 heights"):
        open_heightmap(str(tmp_path / "h.r32"), HeightmapSpec(spacing=1.0, z_range=(0.0, 1.0)))


def test_raw_sizes_that_do_not_fit(tmp_path):
    path = tmp_path / "h.r16"
    np.zeros(1000, "<u2").tofile(path)  # 2000 bytes: 1000 posts, no square
    with pytest.raises(InputError) as err:
        open_heightmap(str(path), HeightmapSpec(spacing=1.0))
    assert str(err.value) == f"{path}: is 2,000 bytes: not a square of 16-bit posts; give --size COLSxROWS"
    with pytest.raises(InputError) as err:
        open_heightmap(str(path), HeightmapSpec(spacing=1.0, size=(30, 30)))
    assert str(err.value) == f"{path}: is 2,000 bytes: --size 30x30 needs 1,800 bytes of 16-bit posts"
    with open_heightmap(str(path), HeightmapSpec(spacing=1.0, size=(40, 25))) as hm:
        assert (hm.grid.rows, hm.grid.cols) == (25, 40)
    empty = tmp_path / "e.r16"
    empty.write_bytes(b"")
    with pytest.raises(InputError, match="file is empty"):
        open_heightmap(str(empty), HeightmapSpec(spacing=1.0))


@pytest.mark.parametrize("spec,message", [
    (HeightmapSpec(), SPACING_NEEDED),
    (HeightmapSpec(spacing=0.0), "--spacing must be a positive number of metres, got 0.0"),
    (HeightmapSpec(spacing=-2.0), "--spacing must be a positive number of metres, got -2.0"),
    (HeightmapSpec(spacing=float("nan")), "--spacing must be a positive number"),
    (HeightmapSpec(spacing=1.0, z_scale=0.0), "--z-scale 0"),
    (HeightmapSpec(spacing=1.0, z_scale=-0.5), "--z-scale must be positive, got -0.5"),
    (HeightmapSpec(spacing=1e-300), "--spacing 1e-300 m is finer than 1e-06 m"),
    (HeightmapSpec(spacing=5e-324), "--spacing 5e-324 m is finer than 1e-06 m"),
    (HeightmapSpec(spacing=1e300), "beyond 1e+09 m"),
    (HeightmapSpec(spacing=1.0, z_range=(5.0, 5.0)), "LOW < HIGH"),
    (HeightmapSpec(spacing=1.0, z_range=(0.0, 5.0), z_scale=2.0), "not both"),
    (HeightmapSpec(spacing=1.0, origin=(0.0, float("inf"))), "--origin"),
])
def test_settings_a_heightmap_cannot_be_read_with(tmp_path, spec, message):
    path = write_png(tmp_path / "h.png", values())
    with pytest.raises(InputError) as err:
        open_heightmap(str(path), spec)
    assert message in str(err.value) and str(err.value).startswith(str(path))


def test_files_that_are_no_heightmap(tmp_path):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40)
    with pytest.raises(InputError, match="not a PNG GDAL can read"):
        open_heightmap(str(bad), HeightmapSpec(spacing=1.0))
    with pytest.raises(InputError, match="no such file"):
        open_heightmap(str(tmp_path / "missing.r16"), HeightmapSpec(spacing=1.0))
    with pytest.raises(InputError, match="--size applies to RAW"):
        open_heightmap(str(write_png(tmp_path / "h.png", values())), HeightmapSpec(spacing=1.0, size=(30, 20)))


def test_what_is_a_heightmap(tmp_path):
    png = write_png(tmp_path / "noext", values())
    assert is_heightmap(str(png))  # by its signature
    assert is_heightmap("x.r16") and is_heightmap("x.RAW") and is_heightmap("x.r32") and is_heightmap("x.png")
    assert not is_heightmap("x.tif") and not is_heightmap("-") and not is_heightmap(str(tmp_path))


def test_size_and_the_options_that_say_the_same():
    assert parse_size("1025x513") == (1025, 513) and parse_size("4X4") == (4, 4)
    for bad in ("1025", "1x5", "ax4", "3x4x5"):
        with pytest.raises(ValueError):
            parse_size(bad)
    spec = HeightmapSpec(spacing=2.0, z_range=(0.0, 600.0), origin=(1.0, 2.0), crs="EPSG:32633", size=(5, 4), band=2)
    assert spec.cli_args() == ["--spacing", "2.0", "--z-range", "0.0", "600.0", "--origin", "1.0", "2.0",
                               "--crs", "EPSG:32633", "--size", "5x4", "--band", "2"]
    assert HeightmapSpec().given() == []


def _rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return 0.0


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="needs /proc")
def test_reading_a_big_raw_window_by_window_keeps_memory_flat(tmp_path):
    path = tmp_path / "big.r16"
    side = 6144  # 72 MB of posts
    with open(path, "wb") as fh:
        fh.truncate(side * side * 2)  # sparse: zeros
    with open_heightmap(str(path), HeightmapSpec(spacing=1.0)) as hm:
        hm.read(0, 256, 0, 256)
        before = _rss_mb()
        for r0 in range(0, side, 512):
            for c0 in range(0, side, 2048):
                hm.read(r0 - 8, r0 + 520, c0 - 8, c0 + 2056)
        grown = _rss_mb() - before
    assert grown < 40, f"memory grew by {grown:.0f} MB reading a {side * side * 2 / 2**20:.0f} MB heightmap"


def test_a_crs_whose_metres_are_not_ground_metres_warns(tmp_path):
    """A heightmap is placed in its --crs, not reprojected: EPSG:3857 at 60 N (metres half a ground
    metre) warns naming the scale; UTM does not; the scale is kept for the store either way."""
    from tankcd_cli.errors import SetupWarning

    path = write_png(tmp_path / "h.png", values())
    merc = HeightmapSpec(spacing=2.0, origin=(1669792.0, 8399737.0), crs="EPSG:3857")
    with pytest.warns(SetupWarning, match=r"EPSG:3857 metres are 0\.50 ground metres here \(point scale 2\.00 at "
                                          r"the centre\): a heightmap is placed, not reprojected"):
        with open_heightmap(str(path), merc) as hm:
            assert hm.info.source_point_scale == pytest.approx(2.0, abs=0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with open_heightmap(str(path), HeightmapSpec(spacing=2.0, origin=(500000.0, 6650000.0),
                                                     crs="EPSG:32633")) as hm:
            assert hm.info.source_point_scale == pytest.approx(0.9996, abs=1e-6)
        with open_heightmap(str(path), HeightmapSpec(spacing=2.0)) as hm:  # a local grid: no scale
            assert hm.info.source_point_scale == 0.0
