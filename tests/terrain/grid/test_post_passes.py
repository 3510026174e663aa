"""The compiled per-post passes (``grid.post_passes``): the numpy twins' bits, the inputs they take
and their errors, many threads at once."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from tankcd_cli.terrain.grid import tiled_classify as gc
from tankcd_cli.terrain.grid import post_passes as k


def _dem(rows, cols, seed):
    rng = np.random.default_rng(seed)
    z = 250 + np.cumsum(rng.normal(0, 0.3, (rows, cols)), axis=1)
    z[rng.random(z.shape) < 0.05] = np.nan
    return z


def test_worker_threads_get_the_numpy_twins_bits():
    dems = [_dem(120 + i, 97, i) for i in range(8)]
    with ThreadPoolExecutor(4) as pool:
        fd = list(pool.map(lambda z: k.fd_mean_curvature(z, 2.0, 0.7), dems))
        areas = list(pool.map(lambda z: k.post_areas(z, 2.0, 0.7), dems))
    for z, h, a in zip(dems, fd, areas):
        np.testing.assert_array_equal(h, gc.grid_mean_curvature_fd(z, 2.0, 0.7))
        np.testing.assert_array_equal(a, gc.post_areas(z, 2.0, 0.7))


def test_inputs_they_take_and_their_errors():
    z = _dem(30, 40, 1)
    ref_h, ref_a = k.fd_mean_curvature(z, 1.0, 1.0), k.post_areas(z, 1.0, 1.0)
    view = np.asfortranarray(z)[::-1][::-1]
    view.flags.writeable = False
    np.testing.assert_array_equal(k.fd_mean_curvature(view, 1, 1), ref_h)
    np.testing.assert_array_equal(k.post_areas(view, 1, 1), ref_a)
    zi = np.round(np.nan_to_num(z)).astype(np.int32)
    np.testing.assert_array_equal(k.post_areas(zi, 1.0, 1.0), k.post_areas(zi.astype(float), 1.0, 1.0))
    h32 = k.fd_mean_curvature(z.astype(np.float32), 1.0, 1.0)  # first differences in float32
    assert h32.dtype == np.float64 and np.allclose(h32, ref_h, atol=1e-3, equal_nan=True)
    for dx, dy in ((0.0, 1.0), (1.0, 0.0), (1e-200, 1.0)):
        with pytest.raises(ZeroDivisionError):
            k.fd_mean_curvature(z, dx, dy)
    assert np.isnan(k.fd_mean_curvature(np.ones((2, 5)), 1.0, 1.0)).all()
    assert k.fd_mean_curvature(np.ones((0, 0)), 1.0, 1.0).shape == (0, 0)
    np.testing.assert_array_equal(k.post_areas(np.ones((1, 4)), 1.0, 1.0), np.zeros((1, 4)))
    for shape in ((0, 4), (3, 0)):
        with pytest.raises(ValueError):
            k.post_areas(np.ones(shape), 1.0, 1.0)


@pytest.mark.parametrize("seed,spacing", [(0, (1.0, 1.0)), (1, (2.0, 0.7)), (2, (0.25, 0.25))])
def test_compiled_twins_give_the_same_bits(seed, spacing):
    """The compiled passes do the numpy twins' arithmetic in the same order: the same bits, NaN included."""
    rng = np.random.default_rng(seed)
    z = 100 + np.cumsum(rng.normal(0, 0.3, (83, 71)), axis=1)
    z[rng.random(z.shape) < 0.07] = np.nan
    np.testing.assert_array_equal(k.fd_mean_curvature(z, *spacing), gc.grid_mean_curvature_fd(z, *spacing))
    np.testing.assert_array_equal(k.post_areas(z, *spacing), gc.post_areas(z, *spacing))
