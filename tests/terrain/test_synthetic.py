"""The analytic terrains the other tests take as truth: their derivatives against finite
differences, H of a sphere and a cylinder in closed form, and the meshes and DEMs sampled from them."""

import numpy as np
import pytest

from tankcd_cli.terrain import synthetic as S

FIELDS = [S.plane(0.3, -0.2, 5.0), S.sphere_cap(30.0), S.cylinder_crest(15.0), S.saddle(0.02, 0.01),
          S.gaussian_hill(4.0, 15.0), S.sinusoid(1.5, 40.0, 60.0)]


@pytest.mark.parametrize("field", FIELDS, ids=lambda f: f.name)
def test_derivatives_are_the_functions_own(field):
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-8, 8, 50), rng.uniform(-8, 8, 50)
    h = 1e-4
    fx, fy = field.grad(x, y)
    np.testing.assert_allclose(fx, (field.f(x + h, y) - field.f(x - h, y)) / (2 * h), rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(fy, (field.f(x, y + h) - field.f(x, y - h)) / (2 * h), rtol=1e-6, atol=1e-8)
    fxx, fxy, fyy = field.hess(x, y)
    gx = lambda dx, dy: field.grad(x + dx, y + dy)  # noqa: E731
    np.testing.assert_allclose(fxx, (gx(h, 0)[0] - gx(-h, 0)[0]) / (2 * h), rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(fxy, (gx(0, h)[0] - gx(0, -h)[0]) / (2 * h), rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(fyy, (gx(0, h)[1] - gx(0, -h)[1]) / (2 * h), rtol=1e-5, atol=1e-7)
    n = field.normal(x, y)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0)
    assert (n[:, 2] > 0).all()


def test_mean_curvature_in_closed_form():
    x, y = np.array([0.0, 3.0, -5.0]), np.array([0.0, 4.0, 2.0])
    np.testing.assert_allclose(S.sphere_cap(30.0).mean_curvature(x, y), 1 / 30)  # a hilltop: positive
    np.testing.assert_allclose(S.cylinder_crest(15.0).mean_curvature(x, y), 1 / 30)
    np.testing.assert_allclose(S.plane(0.3, -0.2).mean_curvature(x, y), 0.0, atol=1e-15)
    assert S.saddle(0.02, 0.01).mean_curvature(np.zeros(1), np.zeros(1))[0] == pytest.approx(-0.01)


def test_sampled_meshes_and_dems():
    V, F, xy = S.grid_mesh(S.gaussian_hill(2.0, 3.0), 4.0, 1.0, offset=(500_000.0, 4_200_000.0, 10.0))
    assert V.shape == (81, 3) and F.shape == (128, 3)
    np.testing.assert_array_equal(V[:, :2], xy + (500_000.0, 4_200_000.0))
    p = xy[F]
    u, v = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    assert (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0] > 0).all()  # counter-clockwise from above
    Vj, Fj, xyj = S.jittered_mesh(S.plane(), 4.0, 1.0, seed=1)
    assert np.abs(xyj - xy).max() <= 1 / 3 + 1e-12 and len(Fj) > 0
    z = np.arange(12.0).reshape(3, 4)  # row 0 south
    z[1, 2] = np.nan
    raw = S.dem_terrain(z, origin=(100.0, 200.0), spacing=2.0)
    g = raw.grid.geometry
    assert (g.rows, g.cols, g.south_west, g.spacing) == (3, 4, (100.0, 200.0), (2.0, 2.0))
    v = raw.grid.vertex  # row 0 north
    assert v[1, 2] == -1 and len(raw.vertices) == 11
    np.testing.assert_array_equal(raw.vertices[v[0, 0]], [100.0, 204.0, 8.0])
    np.testing.assert_array_equal(raw.vertices[v[2, 3]], [106.0, 200.0, 3.0])
    course = S.obstacle_course(0.5)
    assert course.shape == (161, 241) and np.isfinite(course).all()
