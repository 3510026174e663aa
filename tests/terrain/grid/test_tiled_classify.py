"""The tiled classification of a DEM: tiles give the whole raster's bits, curvature against closed
forms, the mesh estimators and classes against the mesh layout, the compiled passes against numpy."""

import numpy as np
import pytest

from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.terrain import synthetic
from tankcd_cli.terrain.grid import tiled_classify as gc
from tankcd_cli.terrain.mesh.classify import classify_mesh
from tests.terrain.grid.dems import T72, THRESHOLDS, classify_arrays, dem_as_mesh, rough_dem


# --- no seams ------------------------------------------------------------------------

@pytest.mark.parametrize("tile", [5, 16, (1, 97), (37, 1000), 64])
@pytest.mark.parametrize("method", ["grid", "cotan"])
def test_tiled_equals_whole_raster(tile, method):
    """Tiles smaller than the halo, tiles of one row, a DEM no multiple of the tile: bit for bit."""
    z = rough_dem(61, 97, seed=1)
    whole = classify_arrays(z, method, tile=10_000)
    tiled = classify_arrays(z, method, tile=tile, jobs=2)
    for k in whole:
        np.testing.assert_array_equal(tiled[k], whole[k], err_msg=k)
    assert (whole["classes"][np.isnan(z)] == 255).all() and np.isnan(whole["mean"][np.isnan(z)]).all()
    assert np.isfinite(whole["mean"][np.isfinite(z)]).all()


@pytest.mark.parametrize("method", ["jet", "sphere"])
def test_tiled_equals_whole_raster_mesh_estimators(method):
    z = rough_dem(40, 45, seed=2)
    np.testing.assert_array_equal(classify_arrays(z, method, tile=13)["mean"],
                                  classify_arrays(z, method, tile=1000)["mean"])


def test_crop_interior_equals_whole():
    """A crop's posts farther than the halo from the cut equal the whole DEM's."""
    z = rough_dem(90, 110, seed=3)
    st = gc.stencils(PostGrid(90, 110), T72.track_length)
    whole = classify_arrays(z)
    r0, r1, c0, c1 = 20, 75, 30, 100
    crop = classify_arrays(z[r0:r1, c0:c1].copy(), tile=17)
    h, w = st.halo_rows, st.halo_cols
    inner = np.s_[h:r1 - r0 - h, w:c1 - c0 - w]
    for k in whole:
        np.testing.assert_array_equal(crop[k][inner], whole[k][r0:r1, c0:c1][inner], err_msg=k)


def test_anisotropic_posts_tiled_equals_whole():
    z = rough_dem(50, 40, seed=4)
    a = classify_arrays(z, tile=1000, dx=2.0, dy=0.75)
    b = classify_arrays(z, tile=(7, 9), dx=2.0, dy=0.75)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])


# --- against independent truths -----------------------------------------------------

@pytest.mark.parametrize("field", [synthetic.sphere_cap(60.0), synthetic.gaussian_hill(3.0, 8.0), synthetic.saddle(0.02, 0.01),
                                   synthetic.plane(0.3, -0.2)], ids=lambda f: f.name)
def test_grid_curvature_converges_to_closed_form(field):
    """Central differences are second order: halving the spacing quarters the interior error."""
    errors = []
    for h in (1.0, 0.5):
        xs = np.arange(-20, 20 + h / 2, h)
        x, y = np.meshgrid(xs, xs[::-1])  # row 0 north
        z = field.f(x, y)
        H = gc.grid_mean_curvature_fd(z, h, h)
        truth = field.mean_curvature(x, y)
        inner = (np.abs(x) < 15) & (np.abs(y) < 15)
        errors.append(np.abs(H[inner] - truth[inner]).max())
    if errors[0] < 1e-12:  # a plane: exact
        assert errors[1] < 1e-12
    else:
        assert errors[1] < errors[0] / 3.5, errors


def test_one_sided_fit_at_edges_is_accurate():
    """Edge and corner posts of a sphere cap (the one-sided quartic) stay within 1 % of 1/R."""
    field = synthetic.sphere_cap(80.0)
    xs = np.arange(-15, 15.5, 1.0)
    x, y = np.meshgrid(xs, xs[::-1])
    out = classify_arrays(field.f(x, y))
    truth = field.mean_curvature(x, y)
    edge = np.zeros(x.shape, bool)
    edge[[0, -1], :] = True
    edge[:, [0, -1]] = True
    assert np.abs(out["mean"][edge] / truth[edge] - 1).max() < 0.01


def test_exactly_flat_is_zero_and_flat():
    out = classify_arrays(np.full((30, 40), 250.0))
    assert (out["mean"] == 0).all() and (out["classes"] == 0).all()


# --- the grid path against the mesh layout --------------------------------------------

@pytest.mark.parametrize("method", ["cotan", "sphere", "jet"])
def test_mesh_estimators_equal_the_mesh_layout(method):
    z = rough_dem(45, 52, seed=5)
    raw = dem_as_mesh(z)
    store = classify_mesh(raw, method=method)
    Hm = np.full(z.shape, np.nan)
    v = raw.grid.vertex  # row 0 north, as the grid's
    Hm[v >= 0] = store.mean_curvature[v[v >= 0]]
    Hg = classify_arrays(z, method, tile=11)["mean"]
    scale = np.nanmax(np.abs(Hm))
    np.testing.assert_allclose(Hg[v >= 0], Hm[v >= 0], rtol=0, atol=1e-12 * scale)


def test_classes_close_to_the_mesh_layout():
    """Both layouts average |H| over the same disks; the mesh layout on a raster of L/8 cells,
    the grid at the posts themselves: the classes agree but for posts near a threshold."""
    from tankcd_cli.terrain.regions import classify_values

    z = rough_dem(150, 150, seed=10, holes=False) * 3
    raw = dem_as_mesh(z)
    store = classify_mesh(raw, method="cotan")
    grid = classify_arrays(z, "cotan")
    vm = np.full(z.shape, np.nan)
    v = raw.grid.vertex
    vm[v >= 0] = store.footprint_curvature[v[v >= 0]]
    agree = grid["classes"] == classify_values(vm, THRESHOLDS)
    assert agree.mean() > 0.97
    near = np.minimum(np.abs(vm - THRESHOLDS.flat) / THRESHOLDS.flat, np.abs(vm - THRESHOLDS.uneven) / THRESHOLDS.uneven)
    assert (near[~agree] < 0.25).all()


# --- the store, read by window ---------------------------------------------------------


# --- compiled twins ----------------------------------------------------------------------


def test_the_compiled_passes_give_the_numpy_passes_result(monkeypatch):
    z = rough_dem(64, 70, seed=14)
    fast = classify_arrays(z, tile=20, jobs=2)
    monkeypatch.setattr(gc, "FAST_MIN_POSTS", 10**12)
    slow = classify_arrays(z, tile=20)
    for key in slow:
        if slow[key].dtype.kind == "f":
            # the passes are bit for bit; the edge posts' quartic fits agree to rounding (compiled
            # normal equations against numpy's), as in test_jet_compiled
            scale = np.nanmax(np.abs(slow[key]))
            np.testing.assert_allclose(fast[key], slow[key], rtol=1e-9, atol=1e-12 * scale)
        else:
            np.testing.assert_array_equal(fast[key], slow[key])


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("method", ["grid", "jet"])
def test_mostly_nodata_raises_no_runtime_warning(tmp_path, method):
    """numpy's RuntimeWarnings never reach the user: a mostly-NODATA EPSG:3857 raster with lone
    posts (no valid neighbour: the one-sided fit once divided inf by inf) classifies quietly, and the
    lone posts get H = 0 (nothing to fit)."""
    import warnings

    rasterio = pytest.importorskip("rasterio")
    from rasterio.transform import Affine

    from tankcd_cli import api
    from tankcd_cli.errors import SetupWarning
    from tankcd_cli.terrain.grid.store import open_grid

    z = np.full((120, 120), -9999.0, dtype=np.float32)
    z[40:44, 30:70] = 50 + np.arange(160, dtype=np.float32).reshape(4, 40) % 7
    z[90, 90] = 3.0  # lone posts
    z[10, 100] = 4.0
    path = tmp_path / "sparse.tif"
    with rasterio.open(path, "w", driver="GTiff", width=120, height=120, count=1, dtype="float32", crs="EPSG:3857",
                       transform=Affine(30, 0, 1669792, 0, -30, 8399737), nodata=-9999) as ds:
        ds.write(z[None])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SetupWarning)  # the scale's, not the point here
        api.classify(str(path), str(tmp_path / "sparse.h5"), method=method, jobs=1, tile=32)
    lone = z.copy()
    lone[z == -9999] = np.nan
    H = gc.one_sided_fit(lone, np.isfinite(lone), 0, 0, 1.0, 1.0, gc.fit_offsets(1.0, 1.0))
    assert H[90, 90] == 0.0 and H[10, 100] == 0.0
    surface = open_grid(str(tmp_path / "sparse.h5"))
    assert surface.grid.rows > 0
    surface.tiles.close()



# --- posts finer than a track feels ------------------------------------------------

def test_class_stride_is_one_down_to_a_hundredth_of_the_track():
    L = T72.track_length
    assert gc.class_stride(PostGrid(9, 9, dx=L / 100, dy=L / 100), L) == (1, 1)
    assert gc.class_stride(PostGrid(9, 9, dx=0.01, dy=0.02), L) == (3, 5)  # rows by dy, columns by dx
    assert gc.class_stride(PostGrid(9, 9, dx=1e-3, dy=1e-3), L) == (43, 43)
    for h in (1e-2, 1e-3, 1e-5):  # what a tile costs no longer grows with the spacing
        plan = gc.tile_plan(PostGrid(5000, 5000, dx=h, dy=h), L, THRESHOLDS)
        assert plan.st.halo_rows == gc.FIT_RADIUS + 1 and len(plan.st.disk_footprint) == 1
        sr, sc = plan.stride
        assert L / 100 <= h * sr < L / 100 + h and len(plan.coarse_st.disk_footprint) <= 7900


@pytest.mark.parametrize("tile", [(30, 23), 1000])
def test_fine_posts_take_the_classes_of_their_coarse_posts(tile):
    """Posts 1 cm apart: H is every post's own (the same bits as without a stride), the footprint
    field each post's nearest coarse post's, the coarse posts classified as a DEM of their own
    (every 5th post, 5 cm apart); any tiling gives the same bits."""
    rows, cols, h = 53, 61, 0.01
    r, c = np.mgrid[0:rows, 0:cols] * h
    z = 10 + 0.02 * np.sin(r / 0.11) * np.cos(c / 0.07) + 0.01 * rough_dem(rows, cols, seed=5, holes=False)
    z[20:24, 30:33] = np.nan
    got = classify_arrays(z, tile=tile, dx=h, dy=h)
    s = 5
    assert gc.class_stride(PostGrid(rows, cols, dx=h, dy=h), T72.track_length) == (s, s)
    coarse = classify_arrays(z[::s, ::s], tile=1000, dx=h * s, dy=h * s)
    near_r = np.minimum((np.arange(rows) + s // 2) // s, (rows - 1) // s)
    near_c = np.minimum((np.arange(cols) + s // 2) // s, (cols - 1) // s)
    expect = coarse["footprint"][np.ix_(near_r, near_c)]
    valid = np.isfinite(z)
    expect = np.where(np.isfinite(expect), expect, np.abs(got["mean"]))
    np.testing.assert_array_equal(got["footprint"][valid], expect[valid])
    np.testing.assert_array_equal(got["classes"][~valid], 255)
    whole = classify_arrays(z, tile=1000, dx=h, dy=h)
    for k in got:
        np.testing.assert_array_equal(got[k], whole[k], err_msg=k)


def test_fine_posts_keep_their_own_curvature(monkeypatch):
    rows, cols, h = 30, 34, 0.03
    z = 5 + 0.01 * rough_dem(rows, cols, seed=6)
    strided = classify_arrays(z, tile=(20, 1000), dx=h, dy=h)
    monkeypatch.setattr(gc, "FINEST_CLASS_POSTS", 10**9)  # no stride: the full disks, 71 posts across
    full = classify_arrays(z, tile=1000, dx=h, dy=h)
    np.testing.assert_array_equal(strided["mean"], full["mean"])
