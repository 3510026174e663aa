"""The compiled footprint pass (Cython): what it does at the edges of its inputs (zero divisors,
any array layout, non-finite poses), and what per-thread scratch must not change."""

import numpy as np
import pytest

from tankcd_cli.threads import get_num_threads, set_num_threads
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.terrain.footprint import footprint_batch
from tankcd_cli.matching.match import EPS_XY, patch_quads
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")
UTM = (500_000.0, 4_500_000.0)


def _args(surface, mode, x, y, yaw, quads, planes, arithmetic=True):
    lx, ly = surface.to_local(x, y)
    return (mode, lx, ly, yaw, quads, planes, EPS_XY, surface.mesh_ground(),
            surface.post_ground() if arithmetic else None)


def _same(a, b):
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
        assert x.dtype == y.dtype


def test_a_zero_cell_size_raises_zero_division_error():
    surface = S.surface_of(S.dem_terrain(np.zeros((10, 10)), origin=UTM))
    q = np.ascontiguousarray(patch_quads(T72, np.zeros(1), np.zeros(1)))
    args = list(_args(surface, 0, [UTM[0] + 5], [UTM[1] + 5], [0.0], q, np.zeros((1, 3)), arithmetic=False))
    args[7] = args[7]._replace(cell_size=np.array([0.0, 1.0]))  # a zero cell size
    with pytest.raises(ZeroDivisionError):
        footprint_batch(*args)


def test_inputs_of_any_layout_and_read_only():
    rng = np.random.default_rng(0)
    surface = S.surface_of(S.dem_terrain(rng.normal(0, 0.2, (40, 40)), origin=UTM))
    n = 50
    x = UTM[0] + rng.uniform(0, 39, 2 * n)[::2]
    y = UTM[1] + rng.uniform(0, 39, n)
    yaw = rng.uniform(-np.pi, np.pi, n)
    quads = patch_quads(T72, rng.normal(0, 0.1, n), rng.normal(0, 0.1, n))
    planes = np.asfortranarray(np.column_stack([rng.normal(0, 1, n), np.zeros(n), np.zeros(n)]))
    for mode in (0, 1):
        want = footprint_batch(*_args(surface, mode, np.ascontiguousarray(x), y, yaw, np.ascontiguousarray(quads),
                                      np.ascontiguousarray(planes)))
        ro = quads.copy()
        ro.setflags(write=False)
        got = footprint_batch(*_args(surface, mode, x, y, np.repeat(yaw, 2)[::2], ro, planes))
        _same(want, got)
    out, covered, status = footprint_batch(*_args(surface, 1, x[:0], y[:0], yaw[:0], quads[:0], planes[:0]))
    assert out.shape == (0, 3) and covered.shape == (0,) and status.dtype == np.int64


@pytest.mark.parametrize("arithmetic", [True, False])
def test_many_points_per_patch_grow_the_scratch_and_threads_change_nothing(arithmetic):
    """5 cm posts: a patch holds thousands of corners, past the first buffers. Pose by pose
    (fresh scratch each time), all at once on one thread and on several: the same bits."""
    rng = np.random.default_rng(1)
    Z = rng.normal(0, 0.02, (160, 160))
    Z[rng.integers(0, 160, 4), rng.integers(0, 160, 4)] = np.nan
    surface = S.surface_of(S.dem_terrain(Z, spacing=0.05, origin=UTM))
    n = 24
    x = UTM[0] + rng.uniform(2, 6, n)
    y = UTM[1] + rng.uniform(2, 6, n)
    yaw = rng.uniform(-np.pi, np.pi, n)
    quads = np.ascontiguousarray(patch_quads(T72, rng.normal(0, 0.05, n), rng.normal(0, 0.05, n)))
    planes = np.column_stack([np.full(n, 0.05), np.zeros(n), np.zeros(n)])
    before = get_num_threads()
    try:
        for mode in (0, 1):
            single = [footprint_batch(*_args(surface, mode, x[i:i + 1], y[i:i + 1], yaw[i:i + 1], quads[i:i + 1],
                                             planes[i:i + 1], arithmetic)) for i in range(n)]
            single = tuple(np.concatenate([s[k] for s in single]) for k in range(3))
            set_num_threads(1)
            one = footprint_batch(*_args(surface, mode, x, y, yaw, quads, planes, arithmetic))
            set_num_threads(max(2, before))
            many = footprint_batch(*_args(surface, mode, x, y, yaw, quads, planes, arithmetic))
            _same(single, one)
            _same(one, many)
            assert (one[2] == 0).all()
    finally:
        set_num_threads(before)


def test_non_finite_and_huge_poses_find_no_ground():
    """Poses at NaN, infinite or beyond-int64 coordinates: no ground under them (the grid path
    finds no cell rather than reading out of bounds)."""
    from tankcd_cli.terrain.grid.surface import GridSurface

    rng = np.random.default_rng(2)
    z = 100 + rng.normal(0, 0.1, (30, 30))
    grid = GridSurface.from_arrays(z, np.zeros(z.shape, np.uint8), PostGrid(*z.shape, UTM[0], UTM[1] + 29.0))
    mesh = S.surface_of(S.dem_terrain(z[::-1], origin=UTM))
    x = UTM[0] + np.array([np.nan, np.inf, -np.inf, 1e19, 9.3e18, 0.0, 0.0, 15.0])
    y = UTM[1] + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1e300, -np.inf, 15.0])
    yaw = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5])
    quads = np.ascontiguousarray(patch_quads(T72, np.zeros(8), np.zeros(8)))
    for mode in (0, 1):
        a = grid.footprint(mode, x, y, yaw, quads, np.zeros((8, 3)), EPS_XY)
        b = mesh.footprint(mode, x, y, yaw, quads, np.zeros((8, 3)), EPS_XY)
        for out, covered, status in (a, b):
            np.testing.assert_array_equal(status, [1] * 7 + [0])
            np.testing.assert_array_equal(covered, [0.0] * 7 + [1.0])
        np.testing.assert_allclose(a[0][-1], b[0][-1], rtol=0, atol=1e-9)
