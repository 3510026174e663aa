"""DEMs through the commands: every raster format to the same store, bad rasters, memory that does
not grow with the terrain, and a classify on a Dask cluster that loses a worker."""

import json
import os
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

rasterio = pytest.importorskip("rasterio")
from rasterio.transform import from_origin  # noqa: E402

from tests.conftest import write_asc  # noqa: E402

X0, YN = 400000.0, 5001000.0  # world x, y of the north-west post


def ground(rows, cols, seed=0):
    """Heights (row 0 north) in 1/64 m steps, so every format (float32 too) stores them exactly, with a NODATA hole."""
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:rows, 0:cols]
    z = 200 + 4 * np.sin(c / 17.0) * np.cos(r / 23.0) + 0.8 * np.sin(c / 3.1 + r / 4.7) + rng.normal(0, 0.05, (rows, cols))
    z = np.round(z * 64) / 64
    z[rows // 3:rows // 3 + 5, cols // 2:cols // 2 + 6] = np.nan
    return z


def write_tif(path, z, x0=X0, yn=YN, d=1.0, **extra):
    profile = dict(driver="GTiff", height=z.shape[0], width=z.shape[1], count=1, dtype="float32", crs="EPSG:32633",
                   transform=from_origin(x0 - d / 2, yn + d / 2, d, d), nodata=-9999.0)
    profile.update(extra)
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(np.where(np.isnan(z), -9999.0, z).astype(profile["dtype"]), 1)
    return path


def rasters_of(z, folder):
    """The same ground as a tiled GeoTIFF, a striped one, a COG, an ESRI grid, and a VRT of four tiles."""
    rows, cols = z.shape
    out = {"tiled": write_tif(folder / "tiled.tif", z, tiled=True, blockxsize=32, blockysize=32),
           "striped": write_tif(folder / "striped.tif", z),
           "cog": write_tif(folder / "cog.tif", z, driver="COG")}
    out["asc"] = write_asc(folder / "g.asc", np.where(np.isnan(z), -9999, z), xll=X0, yll=YN - (rows - 1), nodata=-9999)
    tiles = folder / "tiles"
    tiles.mkdir()
    hr, hc = rows // 2, cols // 2
    for name, (r0, r1, c0, c1) in {"a": (0, hr, 0, hc), "b": (0, hr, hc, cols), "c": (hr, rows, 0, hc),
                                    "d": (hr, rows, hc, cols)}.items():
        write_tif(tiles / f"{name}.tif", z[r0:r1, c0:c1], x0=X0 + c0, yn=YN - r0)
    out["folder"] = tiles
    return out


def store_contents(path):
    with h5py.File(path, "r") as h5:
        h = h5["grid/height"]
        return {"height": h[()].astype(float), "mean": h5["curvature/mean"][()], "classes": h5["classes/grid"][()],
                "origin": (h.attrs["origin_x"], h.attrs["origin_y"]), "spacing": tuple(h.attrs["spacing"])}


def test_every_raster_format_gives_the_same_store(run, tmp_path):
    z = ground(70, 90)
    stores = {}
    for name, src in rasters_of(z, tmp_path).items():
        res = run("classify", src, "-o", tmp_path / f"{name}.h5")
        assert res.exit_code == 0, (name, res.stderr)
        stores[name] = store_contents(tmp_path / f"{name}.h5")
    ref = stores["tiled"]
    np.testing.assert_array_equal(ref["height"], z)
    assert ref["origin"] == (X0, YN) and ref["spacing"] == (1.0, 1.0)
    for name, got in stores.items():
        assert got["origin"] == ref["origin"] and got["spacing"] == ref["spacing"], name
        for key in ("height", "mean", "classes"):
            np.testing.assert_array_equal(got[key], ref[key], err_msg=f"{name} {key}")
    info = json.loads(run("info", tmp_path / "tiled.h5", "--json").stdout)
    assert "UTM zone 33N" in info["crs"] and info["post_spacing"] == [1.0, 1.0]
    assert info["extent_x"] == [X0, X0 + 89] and info["extent_y"] == [YN - 69, YN]


def test_geographic_dem_comes_out_metric(run, tmp_path):
    """An SRTM tile in degrees is warped to its UTM zone; info names the CRS, spacing and extent."""
    import rasterio.shutil

    n = 1201  # 3 arc-second posts over one degree (SRTM-3)
    lon, lat = np.meshgrid(np.linspace(6, 7, n), np.linspace(46, 45, n))
    z = (500 + 200 * np.sin(lon * 9) * np.cos(lat * 7)).astype(np.int16)
    src = tmp_path / "N45E006.tif"
    d = 1.0 / (n - 1)
    with rasterio.open(src, "w", driver="GTiff", height=n, width=n, count=1, dtype="int16", crs="EPSG:4326",
                       transform=from_origin(6 - d / 2, 46 + d / 2, d, d)) as dst:
        dst.write(z, 1)
    hgt = tmp_path / "N45E006.hgt"
    rasterio.shutil.copy(src, hgt, driver="SRTMHGT")
    res = run("classify", hgt, "-o", tmp_path / "srtm.h5")
    assert res.exit_code == 0, res.stderr
    info = json.loads(run("info", tmp_path / "srtm.h5", "--json").stdout)
    assert "UTM zone 32N" in info["crs"] and "WGS 84" in info["reprojected_from"]
    # the extent is the box of the tile's corners in UTM 32N (a degree is about 78 km x 111 km here)
    from rasterio.warp import transform

    xs, ys = transform("EPSG:4326", "EPSG:32632", [6, 7, 6, 7], [45, 45, 46, 46])
    post = info["post_spacing"][0]
    assert abs(info["extent_x"][0] - min(xs)) < 1.5 * post and abs(info["extent_x"][1] - max(xs)) < 1.5 * post
    assert abs(info["extent_y"][0] - min(ys)) < 1.5 * post and abs(info["extent_y"][1] - max(ys)) < 1.5 * post
    assert info["post_spacing"][0] == info["post_spacing"][1] == 92.6
    with h5py.File(tmp_path / "srtm.h5") as h5:
        assert "32632" in h5["grid/height"].attrs["crs"] or "UTM zone 32N" in h5["grid/height"].attrs["crs"]


def test_bad_rasters_exit_3_in_one_line_with_nothing_written(run, tmp_path):
    z = ground(20, 20)
    two = tmp_path / "two.tif"
    with rasterio.open(two, "w", driver="GTiff", height=20, width=20, count=2, dtype="float32", crs="EPSG:32633",
                       transform=from_origin(X0, YN, 1, 1)) as dst:
        dst.write(np.stack([np.nan_to_num(z), np.nan_to_num(z)]).astype(np.float32))
    empty = write_tif(tmp_path / "empty.tif", np.full((8, 8), np.nan))
    cut = write_tif(tmp_path / "cut.tif", z, tiled=True, blockxsize=16, blockysize=16)
    cut.write_bytes(cut.read_bytes()[: cut.stat().st_size // 2])
    rotated = tmp_path / "rotated.tif"
    from affine import Affine

    with rasterio.open(rotated, "w", driver="GTiff", height=20, width=20, count=1, dtype="float32",
                       crs="EPSG:32633", transform=Affine(1, 0.2, X0, 0.2, -1, YN)) as dst:
        dst.write(np.nan_to_num(z).astype(np.float32), 1)
    vrt = tmp_path / "missing.vrt"
    vrt.write_text(f'<VRTDataset rasterXSize="20" rasterYSize="20"><GeoTransform>{X0}, 1, 0, {YN}, 0, -1'
                   '</GeoTransform><VRTRasterBand dataType="Float32" band="1"><SimpleSource><SourceFilename '
                   'relativeToVRT="1">nowhere.tif</SourceFilename><SourceBand>1</SourceBand></SimpleSource>'
                   '</VRTRasterBand></VRTDataset>')
    for src, fragment in ((two, "band"), (empty, "NODATA"), (cut, ""), (rotated, "rotated"), (vrt, "nowhere.tif")):
        out = tmp_path / (src.stem + ".h5")
        res = run("classify", src, "-o", out)
        assert res.exit_code == 3, (src.name, res.stderr)
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and str(src) in lines[0] and fragment in lines[0], res.stderr
        assert not out.exists() and not [p for p in os.listdir(tmp_path) if p.endswith(".part")]
    assert run("classify", two, "--band", "2", "-o", tmp_path / "b2.h5").exit_code == 0


def _peak_rss_mb(args):
    """Run a command in a child and return its exit code and peak resident memory, MB."""
    code = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:], capture_output=True); "
            "print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    out = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, check=True)
    rc, kb = out.stdout.split()
    return int(rc), int(kb) / 1024


def _drive(path, x0, y0, rows=1000):
    """A circle of 50 m radius driven at 0.2 m a row, starting east-bound at (x0, y0)."""
    t = np.arange(rows) * 0.1
    heading = np.arange(rows) * 0.004
    x = x0 + 50 * np.sin(heading)
    y = y0 + 50 * (1 - np.cos(heading))
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg\n")
        np.savetxt(fh, np.column_stack([t, x, y, np.degrees(heading)]), fmt="%.3f", delimiter=",")
    return path


def test_replay_memory_does_not_grow_with_the_terrain(run, tmp_path):
    """A 1,000-row replay reads only the tiles under it: the same poses and the same peak memory
    on a store 64 times larger (the 2,400 x 2,400-post store holds 75 MB of rasters)."""
    rng = np.random.default_rng(5)
    big = 100 + np.cumsum(rng.normal(0, 0.02, (2400, 2400)), axis=1)
    stores = {}
    for n in (300, 2400):  # the small DEM is the big one's north-west corner
        src = write_tif(tmp_path / f"d{n}.tif", big[:n, :n], dtype="float64", tiled=True, blockxsize=256,
                        blockysize=256)
        assert run("classify", src, "-o", tmp_path / f"d{n}.h5").exit_code == 0
        stores[n] = tmp_path / f"d{n}.h5"
    traj = _drive(tmp_path / "t.csv", X0 + 150, YN - 220)
    peaks = {}
    for n, store in stores.items():
        rc, peaks[n] = _peak_rss_mb([sys.executable, "-m", "tankcd_cli", "replay", traj, "--terrain", store,
                                     "--poses", tmp_path / f"p{n}.csv"])
        assert rc == 0
    same = (tmp_path / "p300.csv").read_bytes() == (tmp_path / "p2400.csv").read_bytes()
    assert same, "the poses differ between the corner and the whole"
    assert ",off" not in (tmp_path / "p300.csv").read_text()
    assert os.path.getsize(stores[2400]) > 60e6
    assert peaks[2400] < peaks[300] + 20, peaks  # not the 70 MB more that reading the store would cost


def test_classify_on_a_dask_cluster_that_loses_a_worker(run, tmp_path):
    pytest.importorskip("distributed")
    z = ground(260, 300, seed=3)
    src = write_tif(tmp_path / "d.tif", z, tiled=True, blockxsize=64, blockysize=64)
    assert run("classify", src, "-o", tmp_path / "local.h5", "--tile", "24", "--method", "jet").exit_code == 0
    from tests.conftest import busy_worker, start_dask_cluster, stop_processes

    address, workers, procs = start_dask_cluster(tmp_path)
    try:
        job = subprocess.Popen([sys.executable, "-m", "tankcd_cli", "classify", str(src), "-o",
                                str(tmp_path / "cluster.h5"), "--tile", "24", "--method", "jet", "--scheduler",
                                address], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        from distributed import Client

        with Client(address, timeout=60) as client:  # the kill comes when a worker holds tiles
            victim = busy_worker(client, workers, job, "tile")
            os.kill(victim.pid, signal.SIGKILL)
        _, stderr = job.communicate(timeout=300)
        assert job.returncode == 0, stderr
    finally:
        stop_processes(procs)
    a, b = store_contents(tmp_path / "local.h5"), store_contents(tmp_path / "cluster.h5")
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    with h5py.File(tmp_path / "local.h5") as h1, h5py.File(tmp_path / "cluster.h5") as h2:
        for name in ("overview/classes", "overview/curvature"):
            np.testing.assert_array_equal(h1[name][()], h2[name][()])
        skip = {"created_utc"}
        assert {k: str(v) for k, v in h1.attrs.items() if k not in skip} == \
               {k: str(v) for k, v in h2.attrs.items() if k not in skip}


def test_ascii_grid_through_gdal_equals_our_parser(run, tmp_path, monkeypatch):
    """Large ESRI grids go through GDAL (faster, windowed), small ones through our parser: the same store."""
    import tankcd_cli.terrain.grid.sources as ds

    z = ground(40, 50, seed=8)
    src = write_asc(tmp_path / "g.asc", np.where(np.isnan(z), -9999, z), xll=X0, yll=YN - 39, nodata=-9999)
    assert run("classify", src, "-o", tmp_path / "own.h5").exit_code == 0
    monkeypatch.setattr(ds, "ASC_OWN_MAX_BYTES", 0)
    assert run("classify", src, "-o", tmp_path / "gdal.h5").exit_code == 0
    a, b = store_contents(tmp_path / "own.h5"), store_contents(tmp_path / "gdal.h5")
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_a_damaged_tile_is_exit_3_not_wrong_ground(run, tmp_path):
    """Every tile carries a checksum: bytes flipped inside the store stop the replay in one line."""
    z = ground(300, 300, seed=9)
    src = write_tif(tmp_path / "d.tif", z)
    store = tmp_path / "d.h5"
    assert run("classify", src, "-o", store).exit_code == 0
    with h5py.File(store) as h5:  # where the tile under the drive lies in the file
        offset = h5["grid/height"].id.get_chunk_info_by_coord((0, 0)).byte_offset
    data = bytearray(store.read_bytes())
    data[offset + 1000:offset + 1064] = bytes(255 - b for b in data[offset + 1000:offset + 1064])
    store.write_bytes(bytes(data))
    traj = _drive(tmp_path / "t.csv", X0 + 100, YN - 250, rows=200)
    res = run("replay", traj, "--terrain", store, "--poses", tmp_path / "p.csv")
    assert res.exit_code == 3, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "damaged" in lines[0] and str(store) in lines[0]
    assert not (tmp_path / "p.csv").exists()


def test_a_web_mercator_dem_warns_is_reprojected_and_info_shows_the_scale(run, tmp_path):
    """classify says the scale in one warning line; --strict refuses; info shows the source's point
    scale (--crs choosing without a word: test_rasters)."""
    from tests.io.test_rasters import _write_ramps

    _write_ramps(tmp_path)
    res = run("classify", "ramp_3857.tif", "-o", "m.h5")
    assert res.exit_code == 0, res.stderr
    warnings_said = [line for line in res.stderr.splitlines() if "warning" in line]
    assert warnings_said == ["tankcd: warning: ramp_3857.tif: EPSG:3857 metres are 0.50 ground metres here (point "
                             "scale 2.00 at the centre): reprojected to EPSG:32633; give --crs to choose another"]
    facts = json.loads(run("info", "m.h5", "--json").stdout)
    assert facts["crs"] == "WGS 84 / UTM zone 33N" and facts["reprojected_from"] == "WGS 84 / Pseudo-Mercator"
    assert facts["source_point_scale"]["centre"] == pytest.approx(2.0, rel=2e-3)
    assert facts["post_spacing"] == [1.0, 1.0]
    strict = run("classify", "ramp_3857.tif", "-o", "s.h5", "--strict")
    assert strict.exit_code == 3 and "EPSG:3857 metres are 0.50 ground metres" in strict.stderr
    assert not os.path.exists(tmp_path / "s.h5")
