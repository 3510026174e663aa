"""Terrain height queries against brute force: exact on the triangles, off-terrain reported."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.terrain import synthetic as S


def brute_force_height(V, F, x, y):
    """Highest triangle plane over (x, y) among the triangles containing it, NaN if none."""
    best = np.nan
    for f in F:
        a, b, c = V[f]
        M = np.array([[b[0] - a[0], c[0] - a[0]], [b[1] - a[1], c[1] - a[1]]])
        if abs(np.linalg.det(M)) < 1e-15:
            continue
        l1, l2 = np.linalg.solve(M, [x - a[0], y - a[1]])
        if l1 >= -1e-9 and l2 >= -1e-9 and l1 + l2 <= 1 + 1e-9:
            z = a[2] + l1 * (b[2] - a[2]) + l2 * (c[2] - a[2])
            best = z if np.isnan(best) else max(best, z)
    return best


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 1000), st.booleans(), st.booleans())
def test_heights_match_brute_force(seed, dem, utm):
    offset = (500000.0, 4500000.0, 0.0) if utm else (0.0, 0.0, 0.0)
    field = S.gaussian_hill(3.0, 4.0)
    if dem:
        rng = np.random.default_rng(seed)
        Z = rng.normal(0, 0.5, (9, 11))
        Z[rng.random(Z.shape) < 0.1] = np.nan  # NODATA holes
        raw = S.dem_terrain(Z, origin=offset[:2], spacing=1.5)
    else:
        V, F, _ = S.jittered_mesh(field, 6.0, 1.0, seed=seed, offset=offset)
        raw = S.mesh_terrain(V, F)
    surface = S.surface_of(raw)
    V, F = raw.vertices, raw.faces
    rng = np.random.default_rng(seed)
    lo, hi = V[:, :2].min(axis=0), V[:, :2].max(axis=0)
    pts = np.vstack([rng.uniform(lo - 1, hi + 1, (60, 2)), V[:15, :2], (V[F[:5, 0], :2] + V[F[:5, 1], :2]) / 2])
    z, normal, on = surface.height_normal(pts[:, 0], pts[:, 1])
    for (x, y), zi, oi in zip(pts, z, on):
        truth = brute_force_height(V, F, x, y)
        assert oi == np.isfinite(truth)
        if oi:
            assert zi == pytest.approx(truth, abs=1e-9)
    assert np.allclose(np.linalg.norm(normal[on], axis=1), 1.0)
    assert (normal[on, 2] > 0).all()
    assert np.isnan(z[~on]).all()


def test_vertices_exact_and_normals_of_a_tilted_plane():
    raw = S.dem_terrain(0.2 * np.arange(30)[None, :] - 0.1 * np.arange(20)[:, None] + 100, spacing=2.0)
    surface = S.surface_of(raw)
    z, n, on = surface.height_normal(raw.vertices[:, 0], raw.vertices[:, 1])
    assert on.all()
    np.testing.assert_allclose(z, raw.vertices[:, 2], atol=1e-12)
    expected = np.array([-0.1, 0.05, 1.0]) / np.linalg.norm([-0.1, 0.05, 1.0])
    np.testing.assert_allclose(n, np.broadcast_to(expected, n.shape), atol=1e-12)


def test_region_under_takes_the_worst_class():
    from tankcd_cli.terrain.regions import UNEVEN

    x = np.arange(-40, 41, 1.0)
    X, Y = np.meshgrid(x, x)
    r = np.hypot(X - 20, Y)
    Z = np.where(r < 5, -1.5 * (1 - (r / 5) ** 2) ** 2, 0.0)
    surface = S.surface_of(S.dem_terrain(Z, origin=(-40.0, -40.0)))
    # a footprint whose centre is on flat ground but whose front reaches the crater
    region = surface.region_under(np.array([12.0, -25.0]), np.array([0.0, 0.0]), np.array([0.0, 0.0]), 4.28, 3.37)
    assert region[0] == UNEVEN and region[1] == 0
    off = surface.region_under(np.array([500.0]), np.array([0.0]), np.array([0.0]), 4.28, 3.37)
    assert off[0] == 255


def test_locate_names_the_face_under_each_point():
    V, F, _ = S.jittered_mesh(S.gaussian_hill(2.0, 4.0), 6.0, 1.0, seed=4)
    surface = S.surface_of(S.mesh_terrain(V, F))
    centroids = V[F].mean(axis=1)
    np.testing.assert_array_equal(surface.locate(centroids[:, 0], centroids[:, 1]), np.arange(len(F)))
    assert surface.locate(np.array([100.0]), np.array([0.0]))[0] == -1


def test_ground_above_body_points_matches_height_queries():
    from tankcd_cli.geometry.pose import rotation_matrix

    rng = np.random.default_rng(6)
    Z = rng.normal(0, 0.4, (30, 30))
    Z[5:8, 5:8] = np.nan
    surface = S.surface_of(S.dem_terrain(Z, origin=(500000.0, 4500000.0)))
    n = 200
    R = rotation_matrix(rng.normal(0, 0.2, n), rng.normal(0, 0.2, n), rng.uniform(-3, 3, n))
    pos = np.column_stack([500000 + rng.uniform(0, 29, n), 4500000 + rng.uniform(0, 29, n), rng.normal(0, 0.5, n)])
    pts = rng.uniform(-3, 3, (12, 3))
    got = surface.ground_above(R, pos, pts)
    world = pts @ R.transpose(0, 2, 1) + pos[:, None, :]
    ground, _, _ = surface.height_normal(world[..., 0], world[..., 1])
    want = np.nan_to_num(ground - world[..., 2], nan=-np.inf).max(axis=1)
    np.testing.assert_allclose(got, want, atol=1e-9)
