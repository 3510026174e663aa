"""Quantized heights (terrain/grid/quantum.py): the step found on a sample, the filter that keeps
the classes off the terraces (tiled as the whole raster, bit for bit), and DEMs that are not
quantized classified as before."""

import warnings

import numpy as np
import pytest

from tankcd_cli.errors import SetupWarning
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.dem_source import DemSourceInfo
from tankcd_cli.terrain.grid import quantum as Q
from tankcd_cli.terrain.grid import tiled_classify as gc
from tankcd_cli.terrain.grid.classify import classify_dem, quantized_heights
from tankcd_cli.terrain.grid.sources import ArrayDem
from tests.terrain.grid.dems import T72, THRESHOLDS, classify_arrays, rough_dem


def smooth_ground(rows=150, cols=170, h=1.0):
    r, c = np.mgrid[0:rows, 0:cols] * h
    return 100 + 3 * np.exp(-((r - 70) ** 2 + (c - 90) ** 2) / 900.0) + 0.4 * np.sin(c / 13.0) + 0.002 * r


def rounded(z, q):
    return q * np.round((z - 0.3 * q) / q) + 0.3 * q


def find(z, dtype="float64"):
    return Q.find_quantum(ArrayDem(z).read, *z.shape, height_dtype=dtype)


@pytest.mark.parametrize("q", [0.01, 0.157, 1.0])
def test_the_step_of_rounded_ground_is_found(q):
    found = find(rounded(smooth_ground(), q))
    assert found is not None and found.step == pytest.approx(q, rel=1e-9)
    assert found.shows and found.levels > 2 and found.sampled <= Q.SAMPLE_WINDOWS * Q.SAMPLE_SIDE ** 2


def test_a_step_is_found_from_gaps_that_are_multiples_of_it():
    k = np.round(smooth_ground() / 0.5).astype(int)
    z = 0.25 * ((5 * k) // 2)  # levels 0, 2, 5, 7, 10, ... steps of 0.25: no two a single step apart
    found = find(z)
    assert found is not None and found.step == pytest.approx(0.25, rel=1e-9)


def test_what_is_not_quantized():
    assert find(smooth_ground()) is None  # float heights
    assert find(rough_dem(120, 140, seed=2)) is None  # random walk, NODATA holes
    assert find(np.full((50, 60), 12.5)) is None  # one height: no step to see
    r, c = np.mgrid[0:80, 0:90]
    assert find(100 + 0.01 * c + 0.02 * r) is None  # a plane whose posts fall on a lattice: no terraces
    assert find(100 + 0.01 * (c - 40.0) ** 2 - 0.02 * (r - 40.0) ** 2) is None  # an exact quadratic, likewise
    f32 = smooth_ground().astype(np.float32).astype(np.float64)  # float32's own lattice is no step
    assert find(f32, "float32") is None


def test_rough_ground_rounded_finely_is_found_but_left_as_it_is():
    rng = np.random.default_rng(0)
    z = smooth_ground() + rng.normal(0, 0.05, (150, 170))
    found = find(np.round(z * 64) / 64)  # 1/64 m steps under 5 cm of roughness
    assert found is not None and found.step == pytest.approx(1 / 64) and not found.shows
    grid = PostGrid(150, 170)
    dem = ArrayDem(np.round(z * 64) / 64, grid, DemSourceInfo("r", "array"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert quantized_heights(dem.read, grid, dem.info, THRESHOLDS)[1] == 0  # no warning, no filter


def test_the_passes_follow_from_the_step_and_the_spacing():
    flat = THRESHOLDS.flat
    assert Q.filter_passes(0.001, 1.0, 1.0, flat) == 0  # a survey to the millimetre
    assert Q.filter_passes(1.0, 30.9, 30.9, flat) == 0  # whole metres at 1" posts
    assert Q.filter_passes(0.157, 2.0, 2.0, flat) == 4  # an 8-bit heightmap at 2 m posts
    assert Q.filter_passes(0.05, 1.0, 1.0, flat) == 5
    assert Q.filter_passes(0.05, 1.0, 0.25, flat) == Q.filter_passes(0.05, 0.25, 0.25, flat) == Q.MAX_PASSES
    assert Q.filter_passes(0.1, 1.0, 1.0, 0.0) == Q.MAX_PASSES


def test_the_filter_moves_no_height_more_than_half_a_step_and_keeps_a_plane():
    q = 0.2
    z = rounded(smooth_ground(), q)
    z[40:45, 50:58] = np.nan
    s = Q.smooth_within_quantum(z, q, 6)
    ok = np.isfinite(z)
    assert np.array_equal(np.isfinite(s), ok)
    assert np.abs(s[ok] - z[ok]).max() <= q / 2 + 1e-12
    assert np.abs(s[ok] - z[ok]).max() > q / 4  # it did smooth
    assert np.array_equal(s[0], z[0]) and np.array_equal(s[:, -1], z[:, -1])  # the edges keep their heights
    assert np.array_equal(s[39, 52], z[39, 52])  # beside NODATA too
    r, c = np.mgrid[0:30, 0:40]
    plane = 50 + 0.3 * c - 0.2 * r
    np.testing.assert_allclose(Q.smooth_within_quantum(plane, 0.1, 5), plane, rtol=0, atol=1e-12)
    assert Q.smooth_within_quantum(z, q, 0) is z


def test_the_filter_takes_the_terraces_out_of_the_classes():
    q, h = 0.157, 2.0  # an 8-bit heightmap at 2 m posts
    z = smooth_ground(150, 170, h)
    true = classify_arrays(z, dx=h, dy=h)["classes"]
    terraced = rounded(z, q)
    plain = classify_arrays(terraced, dx=h, dy=h)["classes"]
    passes = Q.filter_passes(q, h, h, THRESHOLDS.flat)
    smoothed, _ = _classify(terraced, h, (q, passes))
    assert (plain == true).mean() < 0.8  # the classes draw the contour lines
    assert (smoothed == true).mean() > 0.95


def _classify(z, h, smoothing, tile=4096, jobs=1, method="grid"):
    rows, cols = z.shape
    out = np.zeros((rows, cols), np.uint8)
    mean = np.zeros((rows, cols))

    def keep(t):
        a, b = t.classes.shape
        out[t.r0:t.r0 + a, t.c0:t.c0 + b] = t.classes
        mean[t.r0:t.r0 + a, t.c0:t.c0 + b] = t.mean
        np.testing.assert_array_equal(t.height, z[t.r0:t.r0 + a, t.c0:t.c0 + b])  # the source's heights kept

    gc.classify_grid_tiles(ArrayDem(z).read, PostGrid(rows, cols, dx=h, dy=h), method, T72.track_length, THRESHOLDS,
                           tile=tile, jobs=jobs, on_tile=keep, smoothing=smoothing)
    return out, mean


@pytest.mark.parametrize("tile,jobs,method", [(37, 1, "grid"), ((29, 53), 2, "grid"), (41, 1, "cotan")])
def test_smoothed_tiles_equal_the_whole_raster_bit_for_bit(tile, jobs, method):
    q, h = 0.1, 1.0
    z = rounded(smooth_ground(110, 130, h), q)
    z[30:36, 40:47] = np.nan
    smoothing = (q, Q.filter_passes(q, h, h, THRESHOLDS.flat))
    assert smoothing[1] >= 8  # a halo wider than the stencils' own
    whole_classes, whole_mean = _classify(z, h, smoothing, tile=1000, method=method)
    classes, mean = _classify(z, h, smoothing, tile=tile, jobs=jobs, method=method)
    np.testing.assert_array_equal(classes, whole_classes)
    np.testing.assert_array_equal(mean, whole_mean)


def test_unquantized_dems_classify_as_before(tmp_path):
    """No step found, no filter: the store's classes are the stencils' alone (the golden tests
    and the rest of tests/terrain/grid/ hold their values)."""
    z = rough_dem(90, 100, seed=4)
    before = classify_arrays(z)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SetupWarning)
        attrs = classify_dem(ArrayDem(z), str(tmp_path / "r.h5"))
    assert attrs["height_quantum"] == 0.0 and attrs["quantum_filter_passes"] == 0
    assert attrs["quantum_filter"] == "none"
    import h5py

    with h5py.File(tmp_path / "r.h5") as h5:
        np.testing.assert_array_equal(h5["classes/grid"][()], np.where(np.isnan(z), 255, before["classes"]))


def test_classify_warns_naming_the_step_and_records_it(tmp_path):
    q, h = 0.157, 2.0
    z = rounded(smooth_ground(100, 120, h), q)
    grid = PostGrid(100, 120, dx=h, dy=h)
    with pytest.warns(SetupWarning) as record:
        attrs = classify_dem(ArrayDem(z, grid, DemSourceInfo("hm.png", "PNG")), str(tmp_path / "q.h5"))
    text = str(record[0].message)
    assert text.startswith("hm.png: heights are quantized in steps of 0.157 m (8-bit?): at 2 m posts")
    assert "smoothed within half a step (4 passes" in text
    assert attrs["height_quantum"] == pytest.approx(q) and attrs["quantum_filter_passes"] == 4
    assert attrs["height_quantum_shows"] and attrs["quantum_filter"].startswith("4 passes")
    with warnings.catch_warnings():
        warnings.simplefilter("error", SetupWarning)  # --strict: bad input before anything is written
        with pytest.raises(SetupWarning):
            classify_dem(ArrayDem(z, grid, DemSourceInfo("hm.png", "PNG")), str(tmp_path / "strict.h5"))
    assert not (tmp_path / "strict.h5").exists()


@pytest.mark.parametrize("spacing,coarse", [(2.0, False), (2.14, False), (2.2, True), (92.6, True)])
def test_posts_wider_than_half_the_track_warn(tmp_path, spacing, coarse):
    z = smooth_ground(30, 30)
    grid = PostGrid(30, 30, dx=spacing, dy=spacing)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        attrs = classify_dem(ArrayDem(z, grid, DemSourceInfo("dem.tif", "GTiff")), str(tmp_path / "c.h5"))
    said = [str(w.message) for w in record if issubclass(w.category, SetupWarning)]
    assert attrs["coarse_posts"] is coarse and attrs["post_spacing_over_track"] == pytest.approx(spacing / 4.28)
    if coarse:
        assert said == [f"dem.tif: posts {spacing:g} m apart are wider than half the t72's 4.28 m track length: the "
                        "classes and the poses cannot resolve the ground the tracks feel (posts at most 2.14 m apart "
                        "would)"]
    else:
        assert said == []
