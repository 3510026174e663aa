"""The grid layout's surface, read by window: heights, poses, footprints and hull contacts equal
the mesh layout's on the same DEM, whatever the windows."""

import numpy as np
import pytest

from tests.terrain.grid.dems import T72, X0, Y0, points


def test_heights_equal_the_mesh_layout(both_surfaces):
    (grid, mesh), z = both_surfaces
    x, y, _ = points(z, 20000, 7)
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
    x, y, yaw = points(z, 3000, 8)
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
    x, y, yaw = points(z, 2000, 9)
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
    x, y, yaw = points(z, 3000, 11)
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
    x, y, yaw = points(z, 3000, 13)
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


def test_windows_do_not_change_results(both_surfaces):
    """The same points queried one by one (each its own window set) and all at once: the same bits."""
    from tankcd_cli.matching.match import match

    (grid, _), z = both_surfaces
    x, y, yaw = points(z, 60, 13)
    together = match(grid, T72, x, y, yaw, "reference")
    for i in range(0, 60, 7):
        alone = match(grid, T72, x[i:i + 1], y[i:i + 1], yaw[i:i + 1], "reference")
        np.testing.assert_array_equal(alone.position, together.position[i:i + 1])
