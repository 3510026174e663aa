"""The grid layout for DEMs: tiled classify, windowed surface, against whole rasters and the mesh layout."""

import dataclasses

import numpy as np
import pytest

from tankcd_cli.terrain.dem_sources import ArrayDem, DemInfo
from tankcd_cli.terrain import grid_classify as gc
from tankcd_cli.terrain import synthetic
from tankcd_cli.terrain.mesh.classify import classify_mesh
from tankcd_cli.terrain.regions import default_thresholds
from tankcd_cli.terrain.mesh.surface import MeshSurface
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")
THRESHOLDS = default_thresholds(T72)
X0, Y0 = 500000.0, 4200000.0  # UTM-like: the south-west post


def rough_dem(rows, cols, seed=0, holes=True):
    """Random-walk heights (row 0 north) with NODATA holes, specks and a missing corner."""
    rng = np.random.default_rng(seed)
    z = 100 + np.cumsum(rng.normal(0, 0.05, (rows, cols)), axis=0) + np.cumsum(rng.normal(0, 0.05, (rows, cols)), axis=1)
    if holes:
        z[rows // 4:rows // 4 + 7, cols // 3:cols // 3 + 9] = np.nan
        z[rng.random(z.shape) < 0.01] = np.nan
        z[:3, :4] = np.nan
        z[-5:, -2:] = np.nan
    return z


def classify_arrays(z, method="grid", tile=gc.DEFAULT_TILE, jobs=1, dx=1.0, dy=1.0):
    """mean, classes (row 0 north) of a DEM by the tiled pipeline."""
    rows, cols = z.shape
    out = {k: np.full((rows, cols), np.nan) for k in ("mean", "footprint", "classes")}

    def keep(t):
        h, w = t.height.shape
        for k in out:
            out[k][t.r0:t.r0 + h, t.c0:t.c0 + w] = getattr(t, k)

    def read(r0, r1, c0, c1):
        return ArrayDem(z, None).read(r0, r1, c0, c1)

    gc.classify_grid_tiles(read, gc.GridGeometry(rows, cols, dx, dy), method, T72.track_length, THRESHOLDS,
                           tile=tile, jobs=jobs, on_tile=keep)
    return out


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
    st = gc.stencils(gc.GridGeometry(90, 110, 1.0, 1.0), T72.track_length)
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

def mesh_store(z):
    raw = synthetic.dem_terrain(z[::-1], origin=(X0, Y0), spacing=1.0)  # the mesh layout numbers rows from the south
    return raw


@pytest.mark.parametrize("method", ["cotan", "sphere", "jet"])
def test_mesh_estimators_equal_the_mesh_layout(method):
    z = rough_dem(45, 52, seed=5)
    raw = mesh_store(z)
    store = classify_mesh(raw, method=method)
    Hm = np.full(z.shape, np.nan)
    v = raw.grid.vertex[::-1]
    Hm[v >= 0] = store.mean_curvature[v[v >= 0]]
    Hg = classify_arrays(z, method, tile=11)["mean"]
    scale = np.nanmax(np.abs(Hm))
    np.testing.assert_allclose(Hg[v >= 0], Hm[v >= 0], rtol=0, atol=1e-12 * scale)


def grid_and_mesh_surfaces(z):
    """The same DEM as a GridSurface (posts only) and a mesh-layout MeshSurface, with the
    mesh's classes on both so that every matcher choice is the same."""
    from tankcd_cli.terrain.grid_surface import GridSurface

    raw = mesh_store(z)
    store = classify_mesh(raw)
    classes = np.full(z.shape, 255, np.uint8)
    v = raw.grid.vertex[::-1]
    classes[v >= 0] = store.vertex_class[v[v >= 0]]
    rows = z.shape[0]
    grid = GridSurface.from_arrays(z.copy(), classes, (X0, Y0 + (rows - 1) * 1.0), (1.0, 1.0))
    mesh = MeshSurface.from_store(store)
    # the mesh layout's class raster replaced by the posts' classes (cells centred on the posts)
    mesh = dataclasses.replace(mesh, class_raster=np.ascontiguousarray(classes[::-1]),
                               class_origin=np.array([X0, Y0]) - mesh.origin, class_cell=1.0)
    return grid, mesh


@pytest.fixture(scope="module")
def both_surfaces():
    import tankcd_cli.terrain.grid_surface as gs

    z = rough_dem(120, 140, seed=6)
    old = gs.BLOCK, gs.WINDOW_POSTS
    gs.BLOCK, gs.WINDOW_POSTS = 32, 20_000  # many windows: results must not depend on them
    try:
        yield grid_and_mesh_surfaces(z), z
    finally:
        gs.BLOCK, gs.WINDOW_POSTS = old


def _points(z, n, seed):
    rng = np.random.default_rng(seed)
    rows, cols = z.shape
    x = X0 + rng.uniform(-4, cols + 3, n)
    y = Y0 + rng.uniform(-4, rows + 3, n)
    k = n // 10
    x[:k] = X0 + rng.integers(0, cols, k)  # exactly on posts
    y[:k] = Y0 + rng.integers(0, rows, k)
    x[k:2 * k] = X0 + rng.integers(0, cols, k) + 0.5  # on grid lines
    return x, y, rng.uniform(-np.pi, np.pi, n)


def test_heights_equal_the_mesh_layout(both_surfaces):
    (grid, mesh), z = both_surfaces
    x, y, _ = _points(z, 20000, 7)
    zg, gxg, gyg = grid.height_slope(x, y)
    zm, gxm, gym = mesh.height_slope(x, y)
    np.testing.assert_array_equal(np.isfinite(zg), np.isfinite(zm))
    ok = np.isfinite(zm)
    np.testing.assert_allclose(zg[ok], zm[ok], rtol=0, atol=1e-9)
    # slopes are one-sided on cell borders; away from them they agree
    u, v = (x - X0) % 1.0, (y - Y0) % 1.0
    inside = ok & (np.minimum(u, 1 - u) > 1e-6) & (np.minimum(v, 1 - v) > 1e-6) & (np.abs(u - v) > 1e-6)
    np.testing.assert_allclose(gxg[inside], gxm[inside], rtol=0, atol=1e-9)
    np.testing.assert_allclose(gyg[inside], gym[inside], rtol=0, atol=1e-9)
    assert np.isnan(grid.height_slope([np.nan, X0 - 50], [Y0, Y0])[0]).all()


@pytest.mark.parametrize("matcher", ["two_point", "four_point", "six_point", "reference", "auto"])
def test_poses_equal_the_mesh_layout(both_surfaces, matcher):
    from tankcd_cli.matching.match import match

    (grid, mesh), z = both_surfaces
    x, y, yaw = _points(z, 3000, 8)
    a = match(grid, T72, x, y, yaw, matcher)
    b = match(mesh, T72, x, y, yaw, matcher)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_array_equal(a.matcher, b.matcher)
    np.testing.assert_array_equal(a.region, b.region)
    for name in ("position", "quaternion", "penetration", "gap", "covered"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-7, err_msg=name)


def test_footprint_arithmetic_equals_clipping_on_posts(both_surfaces):
    """Full cells read by arithmetic give what clipping the posts' triangles gives (the oracle)."""
    from tankcd_cli.collision.terrain_contact import hull_bottom_depth
    from tankcd_cli.matching.match import match

    (grid, _), z = both_surfaces
    x, y, yaw = _points(z, 2000, 9)
    p = match(grid, T72, x, y, yaw, "four_point", measure=False)
    ok = p.status != 2
    fast = hull_bottom_depth(grid, T72, x[ok], y[ok], yaw[ok], p.plane[ok], p.roll[ok], p.pitch[ok])
    slow = hull_bottom_depth(grid, T72, x[ok], y[ok], yaw[ok], p.plane[ok], p.roll[ok], p.pitch[ok], dem=False)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-9)


def test_hull_bound_never_below_the_exact_pass(both_surfaces):
    """The posts' bound over a hull's bottom is never below the exact footprint pass, and tight
    enough to clear most poses; a mesh knows no bound (+inf)."""
    from tankcd_cli.collision.terrain_contact import hull_bottom_face
    from tankcd_cli.matching.match import EPS_XY, match

    (grid, mesh), z = both_surfaces
    x, y, yaw = _points(z, 3000, 11)
    p = match(grid, T72, x, y, yaw, "four_point", measure=False)
    ok = p.status != 2
    x, y, yaw = x[ok], y[ok], yaw[ok]
    quads, bottom = hull_bottom_face(T72, p.plane[ok], p.roll[ok], p.pitch[ok])
    bottom[:, 0] -= np.random.default_rng(12).uniform(0.0, 0.8, len(x))  # many poses now touch
    out, _, status = grid.footprint(1, x, y, yaw, quads, bottom, EPS_XY)
    exact = np.where(status == 0, out[:, 0], -np.inf)
    bound = grid.highest_above_plane_bound(x, y, yaw, quads, bottom)
    assert np.isfinite(exact).sum() > 0.8 * len(x)
    assert np.all(bound >= exact), np.max(exact - bound)
    gap = (bound - exact)[np.isfinite(exact)]
    assert np.median(gap) < 0.3
    assert np.isinf(mesh.highest_above_plane_bound(x, y, yaw, quads, bottom)).all()


@pytest.mark.parametrize("which", [0, 1])
def test_hull_contacts_equal_the_exact_depth(both_surfaces, which):
    from tankcd_cli.collision.terrain_contact import hull_bottom_contacts, hull_bottom_depth
    from tankcd_cli.matching.match import match

    (grid, mesh), z = both_surfaces
    surface = (grid, mesh)[which]
    x, y, yaw = _points(z, 3000, 13)
    p = match(surface, T72, x, y, yaw, "four_point", measure=False)
    ok = np.flatnonzero(p.status != 2)
    plane = p.plane[ok].copy()
    plane[:, 0] -= np.random.default_rng(14).uniform(0.0, 0.6, len(ok))
    args = (surface, T72, x[ok], y[ok], yaw[ok], plane, p.roll[ok], p.pitch[ok])
    depth = hull_bottom_depth(*args)
    hit, got = hull_bottom_contacts(*args, 0.01)
    np.testing.assert_array_equal(hit, np.flatnonzero(depth > 0.01))
    np.testing.assert_array_equal(got, depth[hit])
    assert 0.05 * len(ok) < len(hit) < 0.95 * len(ok)


def test_classes_close_to_the_mesh_layout():
    """Both layouts average |H| over the same disks; the mesh layout on a raster of L/8 cells,
    the grid at the posts themselves: the classes agree but for posts near a threshold."""
    from tankcd_cli.terrain.regions import classify_values

    z = rough_dem(150, 150, seed=10, holes=False) * 3
    raw = mesh_store(z)
    store = classify_mesh(raw, method="cotan")
    grid = classify_arrays(z, "cotan")
    vm = np.full(z.shape, np.nan)
    v = raw.grid.vertex[::-1]
    vm[v >= 0] = store.footprint_curvature[v[v >= 0]]
    agree = grid["classes"] == classify_values(vm, THRESHOLDS)
    assert agree.mean() > 0.97
    near = np.minimum(np.abs(vm - THRESHOLDS.flat) / THRESHOLDS.flat, np.abs(vm - THRESHOLDS.uneven) / THRESHOLDS.uneven)
    assert (near[~agree] < 0.25).all()


# --- the store, read by window ---------------------------------------------------------

def test_store_surface_equals_in_memory_and_cache_is_bounded(tmp_path):
    from tankcd_cli.terrain.dem_classify import classify_dem
    from tankcd_cli.terrain.grid_store import open_grid
    from tankcd_cli.terrain.grid_surface import GridSurface

    z = rough_dem(700, 650, seed=11)
    rows, cols = z.shape
    info = DemInfo("mem", "asc", rows, cols, (X0, Y0 + rows - 1.0), (1.0, 1.0))
    path = str(tmp_path / "s.h5")
    classify_dem(ArrayDem(z, info), path, jobs=2)
    surf = open_grid(path, cache_bytes=2 << 20)
    import h5py

    with h5py.File(path) as h5:
        classes = h5["classes/grid"][()]
        np.testing.assert_array_equal(h5["grid/height"][()], z)
    mem = GridSurface.from_arrays(z, classes, (X0, Y0 + rows - 1.0), (1.0, 1.0))
    x, y, yaw = _points(z, 20000, 12)
    for a, b in zip(surf.height_slope(x, y), mem.height_slope(x, y)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(surf.region_under(x, y, yaw, 4.3, 3.4), mem.region_under(x, y, yaw, 4.3, 3.4))
    assert surf.tiles._bytes <= 2 << 20  # the budget holds while the queries span the whole store
    assert surf.tiles.tiles_read > 0


def test_windows_do_not_change_results(both_surfaces):
    """The same points queried one by one (each its own window set) and all at once: the same bits."""
    from tankcd_cli.matching.match import match

    (grid, _), z = both_surfaces
    x, y, yaw = _points(z, 60, 13)
    together = match(grid, T72, x, y, yaw, "reference")
    for i in range(0, 60, 7):
        alone = match(grid, T72, x[i:i + 1], y[i:i + 1], yaw[i:i + 1], "reference")
        np.testing.assert_array_equal(alone.position, together.position[i:i + 1])


# --- compiled twins ----------------------------------------------------------------------

@pytest.mark.parametrize("seed,spacing", [(0, (1.0, 1.0)), (1, (2.0, 0.7)), (2, (0.25, 0.25))])
def test_compiled_twins_give_the_same_bits(seed, spacing):
    """The compiled passes do the numpy twins' arithmetic in the same order: the same bits, NaN included."""
    from tankcd_cli.terrain import grid_classify_kernels as k

    rng = np.random.default_rng(seed)
    z = 100 + np.cumsum(rng.normal(0, 0.3, (83, 71)), axis=1)
    z[rng.random(z.shape) < 0.07] = np.nan
    np.testing.assert_array_equal(k.fd_mean_curvature(z, *spacing), gc.grid_mean_curvature_fd(z, *spacing))
    np.testing.assert_array_equal(k.post_areas(z, *spacing), gc.post_areas(z, *spacing))


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
