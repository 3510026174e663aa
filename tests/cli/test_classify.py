"""tankcd classify and info as users and scripts run them."""

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from tankcd_cli.terrain.mesh.store import read_mesh_store, write_mesh_store
from tests.conftest import write_asc, write_obj

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


@pytest.fixture(scope="module")
def sample_store(tmp_path_factory):
    from click.testing import CliRunner

    from tankcd_cli.cli.main import cli

    out = tmp_path_factory.mktemp("store") / "bf.h5"
    result = CliRunner().invoke(cli, ["classify", str(SAMPLE / "battlefield.asc"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    return out


def _grid(path):
    """The grid store's rasters (row 0 north) and geometry."""
    with h5py.File(path, "r") as h5:
        h = h5["grid/height"]
        return {"height": h[()], "mean": h5["curvature/mean"][()], "classes": h5["classes/grid"][()],
                "origin": (h.attrs["origin_x"], h.attrs["origin_y"]), "spacing": tuple(h.attrs["spacing"]),
                "attrs": dict(h5.attrs)}


def test_store_follows_the_contract(sample_store):
    with h5py.File(sample_store, "r") as h5:
        assert h5.attrs["layout"] == "grid" and h5.attrs["format_version"] == 2
        h = h5["grid/height"]
        rows, cols = h.shape
        assert (rows, cols) == (161, 241) and h.dtype in (np.float32, np.float64)
        assert h5["curvature/mean"].shape == (rows, cols) and h5["curvature/mean"].dtype.kind == "f"
        assert h5["classes/grid"].shape == (rows, cols) and h5["classes/grid"].dtype == np.uint8
        assert h.chunks is not None and h5["classes/grid"].chunks is not None  # tiles: windows read alone
        assert set(np.unique(h5["classes/grid"][()])) <= {0, 1, 2}
        assert np.isfinite(h5["curvature/mean"][()]).all()
        assert "mesh" not in h5 and "index" not in h5  # no vertex, face or plane arrays for a DEM
        a = h5.attrs
        assert a["tankcd_version"]
        assert a["source"].endswith("battlefield.asc")
        assert a["source_sha256"] == hashlib.sha256((SAMPLE / "battlefield.asc").read_bytes()).hexdigest()
        assert a["curvature_method"] == "grid" and a["diagonal"] == "SW-NE"
        assert 0 < a["threshold_flat"] < a["threshold_uneven"]
        # UTM placement kept to the last digit: the ASC's south-west centre is (500000, 4500000)
        assert h.attrs["origin_x"] == 500000.0 and h.attrs["origin_y"] == 4500000.0 + 160 * 1.0
        assert list(h.attrs["spacing"]) == [1.0, 1.0] and h.attrs["crs"] == ""


def test_sample_has_all_three_classes(sample_store):
    g = _grid(sample_store)
    a = g["attrs"]
    shares = [a[f"share_{c}"] for c in ("flat", "general", "uneven")]
    assert all(s > 0.03 for s in shares) and sum(shares) == pytest.approx(1.0)
    # the plain (west third) is flat, the craters' centres uneven
    rows, cols = g["height"].shape
    x = np.arange(cols)[None, :] + 0.0 * np.arange(rows)[:, None]
    y = (rows - 1 - np.arange(rows))[:, None] + 0.0 * x
    classes = g["classes"]
    assert np.mean(classes[x < 60] == 0) > 0.99
    for cx, cy in ((185, 40), (215, 70), (200, 135)):
        assert (classes[np.hypot(x - cx, y - cy) < 3] == 2).all()


def test_store_round_trip(run, tmp_path, sample_store):
    """Classifying a grid store again with the same settings gives the same rasters."""
    res = run("classify", sample_store, "-o", "again.h5")
    assert res.exit_code == 0, res.stderr
    a, b = _grid(sample_store), _grid(tmp_path / "again.h5")
    for name in ("height", "mean", "classes"):
        np.testing.assert_array_equal(a[name], b[name])
    assert a["origin"] == b["origin"] and a["spacing"] == b["spacing"]
    assert a["attrs"]["source_sha256"] == b["attrs"]["source_sha256"]


def test_store_is_rewritten_in_place_only_when_o_names_it(run, sample_store, tmp_path):
    import shutil

    from tankcd_cli.terrain.store import read_attrs

    sample_store = Path(shutil.copy(sample_store, tmp_path / "copy.h5"))
    before = sample_store.read_bytes()
    res = run("classify", sample_store, "--method", "jet")  # the default output is the input itself
    assert res.exit_code == 2 and "is also TERRAIN" in res.stderr and "-o" in res.stderr
    assert sample_store.read_bytes() == before
    res = run("classify", sample_store, "--method", "jet", "-o", sample_store)
    assert res.exit_code == 0, res.stderr
    assert read_attrs(str(sample_store))["curvature_method"] == "jet"


def test_mesh_store_has_buckets_and_round_trips(run, tmp_path):
    result = run("classify", SAMPLE / "battlefield.obj", "-o", "mesh.h5")
    assert result.exit_code == 0, result.stderr
    a = read_mesh_store(str(tmp_path / "mesh.h5"))
    assert a.grid is None and a.buckets is not None
    write_mesh_store(str(tmp_path / "again.h5"), a)
    b = read_mesh_store(str(tmp_path / "again.h5"))
    np.testing.assert_array_equal(a.buckets.face, b.buckets.face)
    np.testing.assert_array_equal(a.buckets.start, b.buckets.start)


def test_default_output_png_and_info(run, tmp_path):
    src = tmp_path / "hill.asc"
    x = np.arange(-20, 21.0)
    X, Y = np.meshgrid(x, x)
    write_asc(src, 3 * np.exp(-(X**2 + Y**2) / 100))
    result = run("classify", src, "--png", "map.png", "--method", "jet")
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""
    assert "hill.asc -> " in result.stderr and "flat" in result.stderr
    assert (tmp_path / "hill.h5").exists()
    assert (tmp_path / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    info = run("info", tmp_path / "hill.h5")
    assert info.exit_code == 0
    assert "curvature method:" in info.stdout and "jet" in info.stdout
    assert "area uneven:" in info.stdout
    facts = json.loads(run("info", tmp_path / "hill.h5", "--json").stdout)
    assert facts["posts"] == 41 * 41 and facts["curvature_method"] == "jet"


def test_quiet_and_verbose(run, tmp_path):
    src = write_asc(tmp_path / "g.asc", np.zeros((5, 5)))
    quiet = run("-q", "classify", src, "-o", "q.h5")
    assert quiet.exit_code == 0 and quiet.stderr == ""
    loud = run("classify", src, "-o", "v.h5", "-v")
    assert "5 rows x 5 columns of posts, 1 m (x) x 1 m (y) apart, local grid (no CRS)" in loud.stderr


def test_user_thresholds_recorded(run, tmp_path):
    src = write_asc(tmp_path / "g.asc", np.zeros((5, 5)))
    assert run("classify", src, "--thresholds", "0.001", "0.05", "-o", "t.h5").exit_code == 0
    with h5py.File(tmp_path / "t.h5") as h5:
        assert h5.attrs["threshold_flat"] == 0.001 and h5.attrs["threshold_uneven"] == 0.05
    bad = run("classify", src, "--thresholds", "0.05", "0.001")
    assert bad.exit_code == 2


@pytest.mark.parametrize("content,fragment", [
    ("", "file is empty"),
    ("ncols 3\nnrows 3\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2 3\n4 5 6\n7 8\n", "expected 3 x 3 = 9 values"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 inf\n3 4\n", "non-finite height"),
])
def test_bad_input_exit_3_one_line_nothing_left(run, tmp_path, content, fragment):
    src = tmp_path / "bad.asc"
    src.write_text(content)
    (tmp_path / "keep.h5").write_bytes(b"previous result")
    result = run("classify", src, "-o", "keep.h5")
    assert result.exit_code == 3
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "bad.asc" in lines[0] and fragment in lines[0]
    assert "Traceback" not in result.stderr
    assert (tmp_path / "keep.h5").read_bytes() == b"previous result"  # untouched
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".part")]


def test_missing_file_and_bad_store(run, tmp_path):
    result = run("classify", tmp_path / "nope.obj")
    assert result.exit_code == 3 and "no such file" in result.stderr
    (tmp_path / "x.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + b"junk" * 10)
    result = run("info", tmp_path / "x.h5")
    assert result.exit_code == 3 and "x.h5" in result.stderr


def test_output_directory_missing_is_exit_3(run, tmp_path):
    src = write_asc(tmp_path / "g.asc", np.zeros((3, 3)))
    result = run("classify", src, "-o", tmp_path / "no" / "such" / "dir" / "g.h5")
    assert result.exit_code == 3 and "output directory does not exist" in result.stderr


def test_internal_error_is_exit_4(run, tmp_path, monkeypatch):
    src = write_asc(tmp_path / "g.asc", np.zeros((3, 3)))

    def boom(*a, **k):
        raise RuntimeError("simulated bug")
    monkeypatch.setattr("tankcd_cli.terrain.grid.classify.classify_dem", boom)
    result = run("classify", src)
    assert result.exit_code == 4
    assert "internal error" in result.stderr and "please report" in result.stderr
    assert not (tmp_path / "g.h5").exists()


def test_reclassify_from_a_store(run, sample_store, tmp_path):
    result = run("classify", sample_store, "--method", "sphere", "-o", "again.h5")
    assert result.exit_code == 0, result.stderr
    with h5py.File(tmp_path / "again.h5") as new, h5py.File(sample_store) as old:
        np.testing.assert_array_equal(new["grid/height"][()], old["grid/height"][()])
        assert new.attrs["curvature_method"] == "sphere"
        assert new.attrs["source_sha256"] == old.attrs["source_sha256"]
        assert not np.array_equal(new["curvature/mean"][()], old["curvature/mean"][()])


def _tankcd(*args, **kw):
    return subprocess.run([sys.executable, "-m", "tankcd_cli", *map(str, args)], capture_output=True, **kw)


def test_stdin_to_stdout_pipeline(tmp_path):
    src = write_asc(tmp_path / "g.asc", np.arange(16.0).reshape(4, 4))
    proc = _tankcd("classify", "-", "--format", "asc", "-o", "-", input=src.read_bytes())
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout[:8] == b"\x89HDF\r\n\x1a\n"
    (tmp_path / "piped.h5").write_bytes(proc.stdout)
    g = _grid(tmp_path / "piped.h5")
    np.testing.assert_array_equal(g["height"], np.arange(16.0).reshape(4, 4))  # row 0 north, as the file lists it


def test_closed_pipe_exits_quietly(tmp_path):
    src = SAMPLE / "battlefield.asc"
    proc = subprocess.run(f"{sys.executable} -m tankcd_cli classify {src} -o - | head -c 100 > /dev/null",
                          shell=True, capture_output=True, cwd=tmp_path)
    assert b"Traceback" not in proc.stderr and b"Error" not in proc.stderr


def test_help_is_lean():
    """--help loads no numpy, scipy, h5py or trimesh: it must be instant."""
    code = ("import sys; from tankcd_cli.cli.main import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "heavy = [m for m in ('numpy', 'scipy', 'h5py', 'trimesh', 'matplotlib') if m in sys.modules]\n"
            "print('HEAVY=' + ','.join(heavy))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.stdout.strip().splitlines()[-1] == "HEAVY="


def test_version():
    proc = _tankcd("--version", text=True)
    assert proc.returncode == 0 and "tankcd" in proc.stdout


def test_outputs_get_ordinary_permissions_and_info_keeps_utm_digits(run, tmp_path):
    src = write_asc(tmp_path / "g.asc", np.zeros((3, 3)), xll=500123.0, yll=4512345.0)
    assert run("classify", src, "-o", "g.h5").exit_code == 0
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "g.h5").stat().st_mode & 0o777 == 0o666 & ~umask
    out = run("info", "g.h5").stdout
    assert "4512345 to 4512347" in out


@pytest.mark.parametrize("args,message", [
    (["--tile", "64"], "--tile applies to DEM rasters, classified tile by tile; a mesh is classified whole"),
    (["--jobs", "1"], "--jobs applies to DEM rasters, classified tile by tile; a mesh is classified whole"),
])
def test_dem_options_on_a_mesh_are_usage_errors(run, tmp_path, args, message):
    src = write_obj(tmp_path / "m.obj", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    result = run("classify", src, "-o", "m.h5", *args)
    assert result.exit_code == 2
    assert result.stderr.endswith(f"Error: {message}\n"), result.stderr
    assert not (tmp_path / "m.h5").exists()


def test_store_and_map_both_on_stdout_is_a_usage_error(run, tmp_path):
    src = write_asc(tmp_path / "g.asc", np.zeros((5, 5)))
    result = run("classify", src, "-o", "-", "--png", "-")
    assert result.exit_code == 2
    assert result.stderr.endswith("Error: -o/--output and --png both go to standard output (-): give one of them a "
                                  "file\n")


def test_pairs_in_the_closing_line_say_their_order(run, tmp_path):
    src = write_asc(tmp_path / "g.asc", np.zeros((4, 6)))
    result = run("classify", src, "-o", "g.h5")
    assert result.exit_code == 0
    assert f"{src} -> g.h5: 4 rows x 6 columns of posts (24 with data)" in result.stderr


@pytest.mark.parametrize("args", [["missing.h5"], ["missing.h5", "-o", "out.h5"]])
def test_a_missing_store_is_no_such_file(run, args):
    # not "-o/--output missing.h5 is also TERRAIN", nor "unknown terrain format 'h5'"
    result = run("classify", *args)
    assert result.exit_code == 3
    assert result.stderr == "tankcd: error: missing.h5: no such file\n"
