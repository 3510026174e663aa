"""The patch queries both surfaces share (``patches.PatchQueries``): ground heights at points of the
heading frame, and the two footprint queries answered by one pass, on every surface kind."""

import numpy as np
import pytest

from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.matching.match import patch_quads
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")
UTM = (500_000.0, 4_500_000.0)


def test_heights_at_heading_frame_points_are_the_heights_of_those_points():
    """``heights_at`` (one kernel on the grid layout, not forming the points) against
    ``height_slope`` at the same points formed in world coordinates; off the terrain NaN."""
    from tankcd_cli.terrain.grid.surface import GridSurface

    rng = np.random.default_rng(11)
    z = 100 + np.cumsum(rng.normal(0, 0.2, (50, 60)), axis=1)
    x0, y0 = 500_000.0, 4_500_000.0
    grid = GridSurface.from_arrays(z, np.zeros(z.shape, np.uint8), PostGrid(*z.shape, x0, y0 + 49.0))
    mesh = S.surface_of(S.dem_terrain(z[::-1], origin=(x0, y0)))
    n = 400
    x, y = x0 + rng.uniform(-3, 62, n), y0 + rng.uniform(-3, 52, n)  # some footprints over the edge
    yaw = rng.uniform(-4, 4, n)
    pts = rng.uniform(-3, 3, (9, 2))
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    px, py = x[:, None] + c * pts[:, 0] - s * pts[:, 1], y[:, None] + s * pts[:, 0] + c * pts[:, 1]
    for surface in (grid, mesh):
        want = surface.height_slope(px, py)[0]
        got = surface.heights_at(x, y, yaw, pts)
        assert got.shape == (n, 9)
        # the points formed at UTM magnitude carry ~1e-10 m of rounding each; heights_at forms them
        # from local centres, so the two agree to within that times the ground's slope
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-8)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
        assert np.isnan(got).any() and np.isfinite(got).any()
    assert grid.heights_at(x[:0], y[:0], yaw[:0], pts).shape == (0, 9)


@pytest.mark.parametrize("layout", ["dem mesh", "tin", "grid"])
def test_both_queries_from_one_pass_are_the_two_passes(layout):
    """Mode 2 (the certificate's pass): the support plane of mode 0 (started from the given planes,
    as mode 2 starts) and the height of mode 1, bit for bit, on every surface kind, and the plane
    of a level start to rounding; no ground under the patches: NaN height and status 1."""
    from scipy.spatial import Delaunay

    from tankcd_cli.terrain.grid.surface import GridSurface

    rng = np.random.default_rng(3)
    z = 100 + np.cumsum(rng.normal(0, 0.1, (40, 40)), axis=0)
    if layout == "grid":
        surface = GridSurface.from_arrays(z, np.zeros(z.shape, np.uint8), PostGrid(*z.shape, UTM[0], UTM[1] + 39.0))
    elif layout == "tin":
        xy = rng.uniform(0, 39, (1500, 2))
        surface = S.surface_of(S.mesh_terrain(np.column_stack([xy + UTM, 100 + np.sin(xy[:, 0] / 3) * xy[:, 1] / 20]),
                                              Delaunay(xy).simplices.astype(np.int64)))
    else:
        surface = S.surface_of(S.dem_terrain(z, origin=UTM))
    n = 300
    x = UTM[0] + np.append(rng.uniform(4, 35, n - 1), -50.0)  # the last one off the terrain
    y = UTM[1] + np.append(rng.uniform(4, 35, n - 1), 0.0)
    yaw = rng.uniform(-np.pi, np.pi, n)
    quads = np.ascontiguousarray(patch_quads(T72, rng.normal(0, 0.1, n), rng.normal(0, 0.1, n)))
    planes = np.column_stack([rng.normal(100, 1, n), rng.normal(0, 0.1, n), rng.normal(0, 0.1, n)])
    lowest, covered0, status0 = surface.support_plane_under(x, y, yaw, quads, start=planes)
    level_start, _, _ = surface.support_plane_under(x, y, yaw, quads)
    high, covered1, _ = surface.highest_over_patches(x, y, yaw, quads, planes)
    both, high2, covered2, status2 = surface.support_and_highest(x, y, yaw, quads, planes)
    np.testing.assert_array_equal(both, lowest)
    np.testing.assert_allclose(both, level_start, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(status2, status0)
    np.testing.assert_array_equal(covered2, covered0)
    np.testing.assert_array_equal(covered2, covered1)
    np.testing.assert_array_equal(high2[:-1], high[:-1])
    assert np.isnan(high2[-1]) and status2[-1] == 1 and (status2[:-1] == 0).all()
