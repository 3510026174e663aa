"""The compiled mesh-layout queries (``mesh.point_queries``): paths agree, threads, inputs, a numpy twin."""

import numpy as np
import pytest

from tankcd_cli.threads import get_num_threads, set_num_threads
from tankcd_cli.terrain.mesh import point_queries as K
from tankcd_cli.terrain import synthetic as S


def _mesh(s):
    return (s.vertices, s.faces, s.plane, s.cell_origin, s.cell_size, s.cell_shape[0], s.cell_shape[1],
            s.cell_start, s.cell_face)


def _dem_surface(seed, holes=0.1, offset=(500_000.0, 4_500_000.0)):
    rng = np.random.default_rng(seed)
    z = rng.normal(100.0, 2.0, (17, 23))
    z[rng.random(z.shape) < holes] = np.nan
    return S.surface_of(S.dem_terrain(z, origin=offset, spacing=1.5))


def _points(s, n, seed):
    rng = np.random.default_rng(seed)
    lo, hi = s.vertices[:, :2].min(axis=0), s.vertices[:, :2].max(axis=0)
    p = np.vstack([rng.uniform(lo - 2, hi + 2, (n, 2)), s.vertices[:, :2]])
    p[:3] = [np.nan, 0.0], [0.0, np.inf], [-1e300, 1e300]
    return p


def test_importable_names():
    assert K.BARY_EPS == 1e-9
    for name in ("cell_of", "inside_triangle", "locate_one", "locate_faces", "height_one", "heights_slopes",
                 "highest_above", "full_cell"):
        assert callable(getattr(K, name))


@pytest.mark.parametrize("seed", range(3))
def test_posts_arithmetic_equals_the_located_face(seed):
    s = _dem_surface(seed)
    p = _points(s, 3000, seed)
    fast = K.heights_slopes(p[:, 0], p[:, 1], s.post_z, s.post_origin, s.post_size, *_mesh(s))
    slow = K.heights_slopes(p[:, 0], p[:, 1], np.empty((0, 0)), s.post_origin, s.post_size, *_mesh(s))
    assert np.array_equal(np.isfinite(fast[0]), np.isfinite(slow[0]))
    np.testing.assert_allclose(fast[0], slow[0], atol=1e-9, equal_nan=True)
    # gradients: at posts and on edges the faces meeting there differ; random points lie inside one
    for a, b in zip(fast[1:], slow[1:]):
        np.testing.assert_allclose(a[:3000], b[:3000], atol=1e-9, equal_nan=True)
    f = K.locate_faces(p[:, 0], p[:, 1], *_mesh(s))
    assert f.dtype == np.int64 and (f[:3] == -1).all()
    assert np.array_equal(f >= 0, np.isfinite(slow[0]))
    on = f >= 0
    pl = s.plane[f[on]]
    assert np.array_equal(slow[0][on], pl[:, 0] + pl[:, 1] * p[on, 0] + pl[:, 2] * p[on, 1])
    i = int(np.flatnonzero(on)[0])
    assert K.locate_one(p[i, 0], p[i, 1], *_mesh(s)) == f[i]
    assert K.inside_triangle(p[i, 0], p[i, 1], s.vertices, s.faces, f[i])
    one = K.height_one(p[i, 0], p[i, 1], s.post_z, s.post_origin, s.post_size, *_mesh(s))
    assert one == (fast[0][i], fast[1][i], fast[2][i])


def test_highest_above_equals_numpy_twin_at_any_thread_count():
    s = _dem_surface(7, holes=0.2, offset=(0.0, 0.0))
    rng = np.random.default_rng(7)
    n = 2000
    a, b = rng.uniform(-0.4, 0.4, (2, n))
    R = np.zeros((n, 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a), 1.0
    R[:, 0, 2], R[:, 2, 0] = np.sin(b), -np.sin(b)
    pos = np.column_stack([rng.uniform(-3, 36, n), rng.uniform(-3, 27, n), rng.uniform(95, 105, n)])
    body = rng.uniform(-2, 2, (9, 3))
    w = [R[:, j, 0][:, None] * body[:, 0] + R[:, j, 1][:, None] * body[:, 1] + R[:, j, 2][:, None] * body[:, 2]
         + pos[:, j][:, None] for j in range(3)]
    g, _, _ = K.heights_slopes(w[0].ravel(), w[1].ravel(), s.post_z, s.post_origin, s.post_size, *_mesh(s))
    d = np.where(np.isfinite(g), g - w[2].ravel(), -np.inf).reshape(n, -1)
    twin = d.max(axis=1)
    old = get_num_threads()
    try:
        for t in (1, 2, 3):
            set_num_threads(t)
            got = K.highest_above(R, pos, body, s.post_z, s.post_origin, s.post_size, *_mesh(s))
            assert np.array_equal(got, twin)
            hs = K.heights_slopes(w[0].ravel(), w[1].ravel(), s.post_z, s.post_origin, s.post_size, *_mesh(s))
            assert np.array_equal(hs[0], g, equal_nan=True)
    finally:
        set_num_threads(old)
    assert K.highest_above(R[:0], pos[:0], body, s.post_z, s.post_origin, s.post_size, *_mesh(s)).shape == (0,)
    assert (K.highest_above(R, pos, body[:0], s.post_z, s.post_origin, s.post_size, *_mesh(s)) == -np.inf).all()


def test_irregular_mesh_and_inputs():
    V, F, _ = S.jittered_mesh(S.gaussian_hill(3.0, 4.0), 6.0, 1.0, seed=3, offset=(500_000.0, 4_500_000.0, 0.0))
    s = S.surface_of(S.mesh_terrain(V, F))
    assert s.post_z.size == 0
    p = _points(s, 1000, 3)
    ref = K.heights_slopes(p[:, 0].copy(), p[:, 1].copy(), s.post_z, s.post_origin, s.post_size, *_mesh(s))
    ro = p.copy()
    ro.flags.writeable = False
    mesh = list(_mesh(s))
    mesh[1] = mesh[1].astype(np.int32)  # other index dtypes
    got = K.heights_slopes(ro[:, 0], ro[:, 1], s.post_z, list(s.post_origin), s.post_size, *mesh)
    for a, b in zip(ref, got):
        assert np.array_equal(a, b, equal_nan=True)
    e = np.empty(0)
    assert K.locate_faces(e, e, *_mesh(s)).shape == (0,)
    for a in K.heights_slopes(e, e, s.post_z, s.post_origin, s.post_size, *_mesh(s)):
        assert a.shape == (0,) and a.dtype == np.float64
    ny, nx = s.cell_shape
    far = s.cell_origin + s.cell_size * [nx, ny]
    assert K.cell_of(far[0], far[1], s.cell_origin, s.cell_size, ny, nx) == (ny - 1, nx - 1)
