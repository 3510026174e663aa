"""The compiled grid queries (``grid.post_queries``): inputs they accept, windows, threads, a numpy twin."""

import numpy as np
import pytest

from tankcd_cli.threads import get_num_threads, set_num_threads
from tankcd_cli.terrain.grid import post_queries as G


def _dem(rows=25, cols=31, seed=0, holes=0.1):
    rng = np.random.default_rng(seed)
    z = rng.normal(100.0, 3.0, (rows, cols))
    z[rng.random(z.shape) < holes] = np.nan
    return z


def _points(rows, cols, size, n, seed):
    rng = np.random.default_rng(seed)
    p = rng.uniform(-2 * size, (np.array([cols, rows]) + 1) * size, (n, 2))
    p[: n // 4] = np.round(p[: n // 4] / size) * size  # posts and cell borders
    p[:4] = [np.nan, 1.0], [1.0, np.inf], [-1e300, 1e300], [(cols - 1) * size, (rows - 1) * size]
    return p


def test_importable_names():
    assert G.BARY_EPS == 1e-9
    for name in ("full_cell", "grid_height_one", "grid_heights_slopes", "grid_worst_class"):
        assert callable(getattr(G, name))


def test_plane_is_exact_and_off_terrain_is_nan():
    size = np.array([1.5, 2.0])
    rows, cols = 12, 9
    yy, xx = np.mgrid[0:rows, 0:cols]
    z = 0.25 * xx * size[0] - 0.5 * yy * size[1] + 10.0
    p = _points(rows, cols, 1.5, 500, 1)
    zz, gx, gy = G.grid_heights_slopes(p[:, 0], p[:, 1], z, np.zeros(2), size, 0, 0, rows, cols)
    inside = (p[:, 0] >= 0) & (p[:, 0] <= (cols - 1) * size[0]) & (p[:, 1] >= 0) & (p[:, 1] <= (rows - 1) * size[1])
    assert np.isfinite(zz).sum() == inside.sum() and np.isfinite(zz[inside]).all()
    np.testing.assert_allclose(zz[inside], 0.25 * p[inside, 0] - 0.5 * p[inside, 1] + 10.0, atol=1e-9)
    np.testing.assert_allclose(gx[inside], 0.25, atol=1e-12)
    np.testing.assert_allclose(gy[inside], -0.5, atol=1e-12)
    assert np.isnan(gx[~inside]).all() and np.isnan(gy[~inside]).all()
    one = G.grid_height_one(p[7, 0], p[7, 1], z, np.zeros(2), size, 0, 0, rows, cols)
    assert np.array_equal(np.array(one), np.array([zz[7], gx[7], gy[7]]), equal_nan=True)


@pytest.mark.parametrize("seed", range(4))
def test_any_window_gives_the_same_bytes(seed):
    rng = np.random.default_rng(seed)
    z = _dem(seed=seed, holes=0.2)
    rows, cols = z.shape
    p = _points(rows, cols, 1.0, 2000, seed)
    whole = G.grid_heights_slopes(p[:, 0], p[:, 1], z, np.zeros(2), np.ones(2), 0, 0, rows, cols)
    for _ in range(5):
        r0, c0 = rng.integers(0, rows - 2), rng.integers(0, cols - 2)
        r1, c1 = rng.integers(r0 + 2, rows + 1), rng.integers(c0 + 2, cols + 1)
        win = G.grid_heights_slopes(p[:, 0], p[:, 1], z[r0:r1, c0:c1], np.zeros(2), np.ones(2), r0, c0, rows, cols)
        # points whose cell and neighbours lie inside the window read the same posts
        u, v = np.floor(p[:, 0]), np.floor(p[:, 1])
        deep = (u - 1 >= c0) & (u + 2 <= c1 - 1) & (v - 1 >= r0) & (v + 2 <= r1 - 1)
        for a, b in zip(whole, win):
            assert np.array_equal(a[deep], b[deep], equal_nan=True)


def test_inputs_strided_read_only_other_dtypes_and_empty():
    z = _dem()
    rows, cols = z.shape
    p = _points(rows, cols, 1.0, 300, 3)
    ref = G.grid_heights_slopes(p[:, 0].copy(), p[:, 1].copy(), z, np.zeros(2), np.ones(2), 0, 0, rows, cols)
    ro = p.copy()
    ro.flags.writeable = False
    wide = np.zeros((rows, 2 * cols))
    wide[:, ::2] = z
    got = G.grid_heights_slopes(ro[:, 0], ro[:, 1], wide[:, ::2], [0, 0], (1, 1), np.int64(0), 0, rows, cols)
    for a, b in zip(ref, got):
        assert np.array_equal(a, b, equal_nan=True)
    e = np.empty(0)
    for a in G.grid_heights_slopes(e, e, z, np.zeros(2), np.ones(2), 0, 0, rows, cols):
        assert a.shape == (0,) and a.dtype == np.float64
    out = G.grid_worst_class(e, e, e, e, e, np.zeros((2, 2), np.uint8), np.zeros(2), np.ones(2), 0, 0)
    assert out.shape == (0,) and out.dtype == np.uint8


def _worst_class_twin(px, py, yaw, su, sv, classes, origin, size, r_off, c_off):
    """numpy, the same arithmetic in the same order."""
    co, si = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    x = px[:, None] + co * su[None] - si * sv[None]
    y = py[:, None] + si * su[None] + co * sv[None]
    with np.errstate(invalid="ignore"):
        col = np.floor((x - origin[0]) / size[0] + 0.5)
        row = np.floor((y - origin[1]) / size[1] + 0.5)
    ok = np.isfinite(col) & np.isfinite(row)
    col = np.where(ok, col, -1e9).astype(np.int64) - c_off
    row = np.where(ok, row, -1e9).astype(np.int64) - r_off
    ok &= (row >= 0) & (row < classes.shape[0]) & (col >= 0) & (col < classes.shape[1])
    c = np.where(ok, classes[np.clip(row, 0, classes.shape[0] - 1), np.clip(col, 0, classes.shape[1] - 1)], 255)
    c = np.where(c == 255, -1, c.astype(np.int64)).max(axis=1, initial=-1)
    return np.where(c >= 0, c, 255).astype(np.uint8)


@pytest.mark.parametrize("samples", [(2, 2), (5, 3), (13, 9)])
def test_worst_class_equals_numpy_twin_at_any_thread_count(samples):
    rng = np.random.default_rng(sum(samples))
    classes = rng.integers(0, 9, (40, 50)).astype(np.uint8)
    classes[rng.random(classes.shape) < 0.3] = 255
    n = 3000
    px, py = rng.uniform(-10, 110, n), rng.uniform(-10, 90, n)
    yaw = rng.uniform(-7, 7, n)
    yaw[0] = np.nan
    su, sv = (a.ravel() for a in np.meshgrid(np.linspace(-3, 3, samples[0]), np.linspace(-1.5, 1.5, samples[1])))
    args = (px, py, yaw, su, sv, classes, np.array([-1.0, 2.0]), np.array([2.0, 2.0]), 3, 4)
    twin = _worst_class_twin(*args)
    old = get_num_threads()
    try:
        for t in (1, 2, 3):
            set_num_threads(t)
            assert np.array_equal(G.grid_worst_class(*args), twin)
            assert np.array_equal(G.grid_worst_class(*args[:2], np.broadcast_to(0.3, n), *args[3:]),
                                  _worst_class_twin(*args[:2], np.full(n, 0.3), *args[3:]))
    finally:
        set_num_threads(old)


def test_heights_do_not_depend_on_thread_count():
    z = _dem(60, 70, seed=5, holes=0.15)
    p = _points(60, 70, 1.0, 20000, 5)
    old = get_num_threads()
    try:
        outs = []
        for t in (1, 2, 4):
            set_num_threads(t)
            outs.append(G.grid_heights_slopes(p[:, 0], p[:, 1], z, np.zeros(2), np.ones(2), 0, 0, 60, 70))
    finally:
        set_num_threads(old)
    for o in outs[1:]:
        for a, b in zip(outs[0], o):
            assert np.array_equal(a, b, equal_nan=True)


def test_full_cell():
    z = np.array([[1.0, 2.0], [4.0, 8.0]])  # south row first: sw=1, se=2, nw=4, ne=8
    assert G.full_cell(z, 0, 0, 0.5, 0.25, 2.0, 4.0) == (1.0 + 0.5 * 1.0 + 0.25 * 6.0, 0.5, 1.5)
    assert G.full_cell(z, 0, 0, 0.25, 0.5, 2.0, 4.0) == (1.0 + 0.5 * 3.0 + 0.25 * 4.0, 2.0, 0.75)
    z[1, 0] = np.nan
    assert all(np.isnan(G.full_cell(z, 0, 0, 0.5, 0.25, 2.0, 4.0)))
