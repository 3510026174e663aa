"""Heightmaps through the command line and scenes: PNG and RAW give the store a GeoTIFF of the
same grid gives (to the quantum); bad heightmaps are one line, exit 3, nothing written; the
quantization and coarseness warnings, which --strict makes exit 3; what info says of both."""

import csv
import io
import json
import os
import warnings

import h5py
import numpy as np
import pytest

from tests.conftest import write_asc

rasterio = pytest.importorskip("rasterio")
from rasterio.transform import from_origin  # noqa: E402

X0, YN = 500000.0, 4500300.0  # the north-west post
D = 1.5  # post spacing, m
LOW, HIGH = 95.0, 112.0  # the 16-bit range


def ground(rows=90, cols=110):
    """Smooth ground with a crest and a dip, row 0 north."""
    r, c = np.mgrid[0:rows, 0:cols] * D
    z = 100 + 6 * np.exp(-((c - 80) ** 2 + (r - 60) ** 2) / 800.0) - 2.5 * np.exp(-((c - 40) ** 2 + (r - 90) ** 2) / 200.0)
    return z + 0.8 * np.sin(c / 11.0) * np.cos(r / 17.0)


def write_png(path, bands, dtype):
    bands = np.asarray(bands, dtype=dtype)
    bands = bands[None] if bands.ndim == 2 else bands
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(path, "w", driver="PNG", width=bands.shape[2], height=bands.shape[1], count=bands.shape[0],
                           dtype=dtype) as dst:
            dst.write(bands)
    return path


def write_tif(path, z, dtype):
    profile = dict(driver="GTiff", height=z.shape[0], width=z.shape[1], count=1, dtype=dtype, crs="EPSG:32633",
                   transform=from_origin(X0 - D / 2, YN + D / 2, D, D))
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(z.astype(dtype), 1)
    return path


def store(path):
    with h5py.File(path, "r") as h5:
        h = h5["grid/height"]
        return {"height": h[()].astype(float), "mean": h5["curvature/mean"][()], "classes": h5["classes/grid"][()],
                "origin": (h.attrs["origin_x"], h.attrs["origin_y"]), "spacing": tuple(h.attrs["spacing"]),
                "crs": h.attrs["crs_name"], "attrs": dict(h5.attrs)}


PLACE = ["--spacing", str(D), "--origin", str(X0), str(YN), "--crs", "EPSG:32633"]


def test_png_and_raw_give_the_geotiff_store_to_the_quantum(run, tmp_path):
    z = ground()
    scale = (HIGH - LOW) / 65535
    v = np.round((z - LOW) / scale).astype(np.uint16)
    write_tif(tmp_path / "g64.tif", z, "float64")
    write_tif(tmp_path / "g32.tif", z, "float32")
    write_png(tmp_path / "h.png", v, "uint16")
    v.astype("<u2").tofile(tmp_path / "h.r16")
    z.astype("<f4").tofile(tmp_path / "h.r32")
    runs = {"g64": ["g64.tif"], "g32": ["g32.tif"],
            "png": ["h.png", *PLACE, "--z-range", str(LOW), str(HIGH)],
            "r16": ["h.r16", "--size", f"{z.shape[1]}x{z.shape[0]}", *PLACE, "--z-scale", repr(scale),
                    "--z-offset", str(LOW)],
            "r32": ["h.r32", "--size", f"{z.shape[1]}x{z.shape[0]}", *PLACE]}
    got = {}
    for name, args in runs.items():
        res = run("classify", *args, "-o", f"{name}.h5")
        assert res.exit_code == 0, (name, res.stderr)
        assert "warning" not in res.stderr, (name, res.stderr)
        got[name] = store(tmp_path / f"{name}.h5")
    tif = got["g64"]
    for name in ("png", "r16", "r32"):
        assert got[name]["origin"] == tif["origin"] and got[name]["spacing"] == tif["spacing"]
        assert got[name]["crs"] == tif["crs"]
    # the 16-bit heightmaps: the GeoTIFF's heights to half a step, its classes but at a handful of posts
    for name in ("png", "r16"):
        assert np.abs(got[name]["height"] - tif["height"]).max() <= scale / 2 + 1e-9
        assert (got[name]["classes"] == tif["classes"]).mean() > 0.995
        assert got[name]["attrs"]["quantum_filter_passes"] == 0  # a 0.26 mm step: nothing to smooth at 1.5 m
    for key in ("height", "mean", "classes"):  # a PNG and a RAW of the same values: the same store
        np.testing.assert_array_equal(got["png"][key], got["r16"][key], err_msg=key)
        np.testing.assert_array_equal(got["r32"][key], got["g32"][key], err_msg=key)  # float32 both: bit for bit
    reading = json.loads(got["png"]["attrs"]["heightmap"])
    assert reading["bits"] == 16 and reading["z_range"] == [LOW, HIGH] and reading["origin"] == [X0, YN]
    assert got["g64"]["attrs"]["heightmap"] == ""


def _nothing_written(tmp_path, before):
    assert sorted(os.listdir(tmp_path)) == before, "an output (or a temporary) was left behind"


@pytest.mark.parametrize("name,args,message", [
    ("rgb.png", ["--spacing", "1"], "has colour channels (red, green, blue): give --band N to use one"),
    ("odd.r16", ["--spacing", "1"], "is 2,000 bytes: not a square of 16-bit posts; give --size COLSxROWS"),
    ("odd.r16", ["--spacing", "1", "--size", "30x30"], "is 2,000 bytes: --size 30x30 needs 1,800 bytes of 16-bit posts"),
    ("grey.png", ["--spacing", "0"], "--spacing must be a positive number of metres, got 0.0"),
    ("grey.png", ["--spacing", "-2.5"], "--spacing must be a positive number of metres, got -2.5"),
    ("grey.png", [], "a heightmap holds no post spacing: give --spacing M"),
    ("grey.png", ["--spacing", "1e-300"], "--spacing 1e-300 m is finer than 1e-06 m (a micrometre)"),
    ("grey.png", ["--spacing", "1e300"], "--spacing 1e+300 m over 12 posts spans 1.1e+301 m, beyond 1e+09 m"),
    ("grey.png", ["--spacing", "1", "--z-scale", "-0.5"], "--z-scale must be positive, got -0.5"),
    ("odd.r16", [], "a heightmap holds no post spacing: give --spacing M"),
])
def test_bad_heightmaps_are_one_line_exit_3_nothing_written(run, tmp_path, name, args, message):
    write_png(tmp_path / "rgb.png", np.zeros((3, 12, 12)), "uint8")
    write_png(tmp_path / "grey.png", np.arange(144).reshape(12, 12), "uint16")
    np.zeros(1000, "<u2").tofile(tmp_path / "odd.r16")
    before = sorted(os.listdir(tmp_path))
    res = run("classify", name, *args, "-o", "out.h5", "--png", "map.png")
    assert res.exit_code == 3, res.stderr
    assert res.stderr == f"tankcd: error: {name}: {message}" + res.stderr.split(message, 1)[1]
    assert res.stderr.count("\n") == 1 and message in res.stderr
    _nothing_written(tmp_path, before)


def test_heightmap_options_for_other_inputs_are_usage_errors(run, tmp_path):
    write_asc(tmp_path / "g.asc", np.ones((5, 5)))
    for args in (["--spacing", "2"], ["--z-range", "0", "10"], ["--size", "5x5"], ["--origin", "0", "0"]):
        res = run("classify", "g.asc", *args, "-o", "g.h5")
        assert res.exit_code == 2 and "applies to heightmaps (PNG, RAW)" in res.stderr, (args, res.stderr)
    res = run("classify", "g.asc", "--size", "5by5", "-o", "g.h5")
    assert res.exit_code == 2 and "--size" in res.stderr


def eight_bit(tmp_path, spacing=2.0):
    """An 8-bit heightmap of smooth ground, 40 m of relief: 0.157 m steps."""
    z = ground(120, 140)
    v = np.round((z - z.min()) / (z.max() - z.min()) * 255)
    return write_png(tmp_path / "hm8.png", v, "uint8"), (z.max() - z.min()) / 255


def test_an_8_bit_heightmap_warns_and_its_classes_leave_the_terraces(run, tmp_path):
    eight_bit(tmp_path)
    res = run("classify", "hm8.png", "--spacing", "2", "--z-range", "0", "40", "-o", "hm8.h5")
    assert res.exit_code == 0, res.stderr
    warning = [line for line in res.stderr.splitlines() if "warning" in line]
    assert warning == ["tankcd: warning: hm8.png: heights are quantized in steps of 0.157 m (8-bit values): at 2 m "
                       "posts the classes would follow the terraces; the curvature is taken from the heights smoothed "
                       "within half a step (4 passes; the store keeps the source heights)"]
    a = store(tmp_path / "hm8.h5")["attrs"]
    assert a["height_quantum"] == pytest.approx(40 / 255) and a["quantum_filter_passes"] == 4
    plain = run("-q", "classify", "hm8.png", "--spacing", "2", "--z-range", "0", "40", "-o", "q.h5")
    assert plain.exit_code == 0 and plain.stderr == ""  # -q: no warning
    before = sorted(os.listdir(tmp_path))
    strict = run("classify", "hm8.png", "--spacing", "2", "--z-range", "0", "40", "-o", "s.h5", "--strict")
    assert strict.exit_code == 3 and "heights are quantized in steps of 0.157 m" in strict.stderr
    assert strict.stderr.endswith("(--strict)\n") and strict.stderr.count("\n") == 1
    _nothing_written(tmp_path, before)


def test_coarse_posts_warn_and_strict_refuses(run, tmp_path):
    rng = np.random.default_rng(1)
    write_asc(tmp_path / "srtm.asc", 300 + rng.normal(0, 3, (20, 20)), cellsize=92.6, xll=X0, yll=4500000.0)
    res = run("classify", "srtm.asc", "-o", "srtm.h5")
    assert res.exit_code == 0, res.stderr
    assert ("tankcd: warning: srtm.asc: posts 92.6 m apart are wider than half the t72's 4.28 m track length: the "
            "classes and the poses cannot resolve the ground the tracks feel (posts at most 2.14 m apart would)\n"
            ) in res.stderr
    before = sorted(os.listdir(tmp_path))
    strict = run("classify", "srtm.asc", "-o", "s.h5", "--strict")
    assert strict.exit_code == 3 and "posts 92.6 m apart" in strict.stderr and "(--strict)" in strict.stderr
    _nothing_written(tmp_path, before)
    # replay gets the same check from the terrain layer, on the store and on the DEM classified on the fly
    for terrain in ("srtm.h5", "srtm.asc"):
        rep = run("replay", "-", "--terrain", terrain, input="t,x,y,yaw_deg\n0,500900,4500900,0\n")
        assert rep.exit_code == 0, rep.stderr
        assert rep.stderr.count("posts 92.6 m apart are wider than half the t72's 4.28 m track length") == 1
        assert run("replay", "-", "--terrain", terrain, "--strict",
                   input="t,x,y,yaw_deg\n0,500900,4500900,0\n").exit_code == 3


def test_verbose_says_what_was_ignored(run, tmp_path):
    v = np.arange(400).reshape(20, 20) * 100
    write_png(tmp_path / "ga.png", np.stack([v, np.full_like(v, 65535)]), "uint16")
    res = run("classify", "ga.png", "--spacing", "1", "-o", "ga.h5", "-v")
    assert res.exit_code == 0, res.stderr
    assert "classify: ga.png: PNG heightmap: 16-bit values, 20 columns x 20 rows; row 0 (the top) north" in res.stderr
    assert "classify: ga.png: alpha channel ignored (a heightmap has no missing posts)" in res.stderr


def test_info_shows_the_quantum_and_the_spacing_against_the_track(run, tmp_path):
    eight_bit(tmp_path)
    assert run("classify", "hm8.png", "--spacing", "2", "--z-range", "0", "40", "-o", "hm8.h5").exit_code == 0
    write_asc(tmp_path / "fine.asc", ground(40, 40), cellsize=1.0)
    assert run("classify", "fine.asc", "-o", "fine.h5").exit_code == 0
    facts = json.loads(run("info", "hm8.h5", "--json").stdout)
    q = facts["height_quantum"]
    assert q["step"] == pytest.approx(40 / 255) and q["smoothing_passes"] == 4 and q["levels"] <= 256
    assert "smoothed within half a step" in q["classes"]
    track = facts["post_spacing_against_track"]
    assert track == {"spacing": 2.0, "track_length": 4.28, "ratio": round(2 / 4.28, 4),
                     "verdict": "fine enough: at most half the track length"}
    assert facts["heightmap"]["z_range"] == [0.0, 40.0] and facts["heightmap"]["bits"] == 8
    fine = json.loads(run("info", "fine.h5", "--json").stdout)
    assert fine["height_quantum"]["step"] is None and "heightmap" not in fine
    text = run("info", "hm8.h5").stdout
    assert "height quantum:" in text and "smoothing passes:   4" in text and "post spacing against track:" in text


def scene(tmp_path, terrain_keys):
    (tmp_path / "scene.toml").write_text("[terrain]\n" + terrain_keys + "\n[vehicle]\npreset = \"t72\"\n")
    return tmp_path / "scene.toml"


def test_a_scene_reads_a_heightmap_as_its_terrain_table_says(run, tmp_path):
    z = ground()
    v = np.round((z - LOW) / (HIGH - LOW) * 65535).astype("<u2")
    v.tofile(tmp_path / "hm.raw")
    keys = (f'path = "hm.raw"\nspacing = {D}\nz_range = [{LOW}, {HIGH}]\norigin = [{X0}, {YN}]\n'
            f'size = "{z.shape[1]}x{z.shape[0]}"\ncrs = "EPSG:32633"\n')
    scene(tmp_path, keys)
    facts = json.loads(run("info", "scene.toml", "--json").stdout)
    t = facts["terrain"]
    assert t["heightmap"] == {"spacing": D, "z_range": [LOW, HIGH], "origin": [X0, YN], "crs": "EPSG:32633",
                              "size": [z.shape[1], z.shape[0]]}
    assert t["kind"].startswith("DEM (RAW, 90 rows x 110 columns") and "UTM zone 33N" in t["crs"]
    assert t["extent_x"] == [X0, X0 + 109 * D] and t["extent_y"] == [YN - 89 * D, YN]
    rows = "t,x,y,yaw_deg\n" + "".join(f"{k},{X0 + 40 + 3 * k},{YN - 60},0\n" for k in range(8))
    res = run("replay", "-", "--scene", "scene.toml", input=rows)
    assert res.exit_code == 0, res.stderr
    poses = list(csv.DictReader(io.StringIO(res.stdout)))
    assert len(poses) == 8 and {p["status"] for p in poses} == {"ok"}
    # the heights are the heightmap's: the store of classify with the same options
    assert run("classify", "hm.raw", "--spacing", str(D), "--z-range", str(LOW), str(HIGH), "--origin", str(X0),
               str(YN), "--size", f"{z.shape[1]}x{z.shape[0]}", "--crs", "EPSG:32633", "-o", "hm.h5").exit_code == 0
    again = run("replay", "-", "--terrain", "hm.h5", input=rows)
    assert again.stdout == res.stdout


@pytest.mark.parametrize("keys,where,fragment", [
    ('path = "hm.png"\nspacing = 0', "[terrain] spacing", "spacing must be a positive number"),
    ('path = "hm.png"\nspacing = -1.0', "[terrain] spacing", "spacing must be a positive number"),
    ('path = "hm.png"\nspacing = 2\nz_range = [5, 1]', "[terrain] z_range", "LOW < HIGH"),
    ('path = "hm.png"\nspacing = 2\nz_scale = -1', "[terrain] z_scale", "z_scale must be a positive number"),
    ('path = "g.asc"\nspacing = 2\ncrs = "EPSG:32633"', "[terrain] spacing", "describes a heightmap"),
    ('path = "hm.png"\nspacing = 2\nz_range = [0, 1]\nz_scale = 2', "[terrain] z_scale", "not both"),
    ('path = "hm.png"\nspacing = 2\norigin = [1]', "[terrain] origin", "two finite numbers"),
    ('path = "hm.png"\nspacing = 2\nsize = "big"', "[terrain] size", "COLSxROWS"),
    ('path = "hm.png"\nspacing = 2\nband = 0', "[terrain] band", "whole number"),
    ('path = "g.asc"\nspacing = 2', "[terrain] spacing", "describes a heightmap (PNG, RAW); g.asc is none"),
    ('spacing = 2', "[terrain] spacing", "names no [terrain] path"),
])
def test_bad_heightmap_keys_in_a_scene_are_exit_3_naming_the_key(run, tmp_path, keys, where, fragment):
    write_png(tmp_path / "hm.png", np.arange(144).reshape(12, 12), "uint16")
    write_asc(tmp_path / "g.asc", np.ones((5, 5)))
    scene(tmp_path, keys)
    res = run("info", "scene.toml")
    assert res.exit_code == 3, res.stderr
    assert f"scene.toml: {where}: " in res.stderr and fragment in res.stderr and res.stderr.count("\n") == 1


def test_a_scene_heightmap_without_spacing_names_the_key(run, tmp_path):
    write_png(tmp_path / "hm.png", np.arange(144).reshape(12, 12), "uint16")
    scene(tmp_path, 'path = "hm.png"')
    res = run("replay", "-", "--scene", "scene.toml", input="t,x,y,yaw_deg\n0,5,5,0\n")
    assert res.exit_code == 3 and "spacing = M in the scene's [terrain] table" in res.stderr


def test_posts_finer_than_a_track_feels_warn_and_stay_bounded(run, tmp_path):
    """--spacing 0.001 on a 200 x 200 heightmap (20 cm of ground): once minutes and gigabytes, now
    the classes on one post in 43 (4.3 cm apart), said in a warning; --strict refuses it."""
    r, c = np.mgrid[0:200, 0:200]
    write_png(tmp_path / "fine.png", 30000 + 20000 * np.sin(r / 30) * np.cos(c / 40), "uint16")
    res = run("classify", "fine.png", "--spacing", "0.001", "--z-scale", "1e-7", "-o", "fine.h5")
    assert res.exit_code == 0, res.stderr
    assert ("tankcd: warning: fine.png: posts 0.001 m apart are far finer than anything the t72's tracks feel (1/100 "
            "of its 4.28 m track length is 0.0428 m): the classes are computed on one post in 43 (0.043 m apart), "
            "each post taking the nearest one's; heights and curvature keep every post\n") in res.stderr
    got = store(tmp_path / "fine.h5")
    assert list(got["attrs"]["class_post_stride"]) == [43, 43] and got["spacing"] == (0.001, 0.001)
    assert np.isfinite(got["mean"]).all() and (got["classes"] < 3).all()
    coarse = run("-q", "classify", "fine.png", "--spacing", "0.5", "-o", "c.h5")
    assert coarse.exit_code == 0 and list(store(tmp_path / "c.h5")["attrs"]["class_post_stride"]) == [1, 1]
    before = sorted(os.listdir(tmp_path))
    strict = run("classify", "fine.png", "--spacing", "0.001", "-o", "s.h5", "--strict")
    assert strict.exit_code == 3 and "far finer than anything" in strict.stderr
    _nothing_written(tmp_path, before)
