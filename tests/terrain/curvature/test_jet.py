"""The jet estimator in numpy: its neighbour rule against a brute-force sort, its fit exact on
quartics, its accuracy on irregular meshes."""

import numpy as np
import pytest

from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.curvature.jet import jet_fit_numpy, nearest_neighbours
from tankcd_cli.terrain.curvature.mean import mean_curvature

HALF = 12.0
SURFACES = {
    "sphere_cap": S.sphere_cap(30.0),
    "saddle": S.saddle(0.02, 0.01),
    "gaussian_hill": S.gaussian_hill(4.0, 15.0),
}


def relative_error(H, truth):
    floor = 0.1 * np.abs(truth).max()
    return np.abs(H - truth) / np.maximum(np.abs(truth), floor)


def interior(xy, spacing, margin=2):
    return np.minimum(HALF - np.abs(xy[:, 0]), HALF - np.abs(xy[:, 1])) > margin * spacing


@pytest.mark.parametrize("fast", [False, True])
def test_nearest_neighbours_by_a_brute_force_sort(fast):
    """The k nearest other points by distance, equal distances by index: a stable sort of
    all distances, on a regular grid (all ties) and on random points."""
    rng = np.random.default_rng(5)
    grid = np.column_stack([np.tile(np.arange(7.0), 7), np.repeat(np.arange(7.0), 7), np.zeros(49)])
    for V in (grid, rng.uniform(0, 10, (200, 3))):
        which = np.zeros(len(V), dtype=bool)
        which[::3] = True
        got = nearest_neighbours(V, which, 8, fast=fast)
        for row, i in zip(got, np.flatnonzero(which)):
            d = np.round(np.linalg.norm(V - V[i], axis=1), 9)
            order = [j for j in np.lexsort((np.arange(len(V)), d)) if j != i]
            assert list(row) == order[:8]


def test_the_fit_is_exact_on_a_quartic():
    """A quartic height field is its own jet: H at the centre is the closed form to round-off,
    tilted or not."""
    field = S.HeightField("quartic", lambda x, y: 0.02 * x**2 - 0.01 * x * y + 0.003 * x**3 * y + 0.001 * y**4,
                          lambda x, y: (0.04 * x - 0.01 * y + 0.009 * x**2 * y, -0.01 * x + 0.003 * x**3 + 0.004 * y**3),
                          lambda x, y: (0.04 + 0.018 * x * y, -0.01 + 0.009 * x**2, 0.012 * y**2))
    V, F, xy = S.grid_mesh(field, 3.0, 1.0)
    centre = int(np.argmin(np.hypot(xy[:, 0], xy[:, 1])))
    others = np.array([i for i in range(len(V)) if i != centre])
    normal = np.tile([0.0, 0.0, 1.0], (len(V), 1))
    H = jet_fit_numpy(V, normal, np.array([centre]), others[None, :], 4)
    assert H[0] == pytest.approx(field.mean_curvature(np.zeros(1), np.zeros(1))[0], rel=1e-9)


@pytest.mark.parametrize("name", ["sphere_cap", "saddle", "gaussian_hill"])
def test_jet_meets_targets_on_jittered_delaunay(name):
    """Accurate method: <= 0.5 % median and 5 % worst relative error at 1 m spacing."""
    field = SURFACES[name]
    for seed in (0, 1, 2):
        V, F, xy = S.jittered_mesh(field, HALF, 1.0, seed=seed)
        truth = field.mean_curvature(xy[:, 0], xy[:, 1])
        err = relative_error(mean_curvature(V, F, "jet"), truth)
        inner = interior(xy, 1.0)
        assert np.median(err[inner]) < 0.005
        assert err[inner].max() < 0.05
