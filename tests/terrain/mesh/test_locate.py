"""Triangle buckets: every point's containing triangle is among its bucket's candidates."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.mesh.locate import build_buckets


def containing_triangles_brute_force(V, F, p):
    a, b, c = V[F][:, 0, :2], V[F][:, 1, :2], V[F][:, 2, :2]

    def side(u, v, q):
        return (v[:, 0] - u[:, 0]) * (q[1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (q[0] - u[:, 0])
    s0, s1, s2 = side(a, b, p), side(b, c, p), side(c, a, p)
    inside = ((s0 >= 0) & (s1 >= 0) & (s2 >= 0)) | ((s0 <= 0) & (s1 <= 0) & (s2 <= 0))
    return set(np.flatnonzero(inside))


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.3, 3.0), st.booleans())
def test_buckets_hold_the_containing_triangle(seed, spacing, utm):
    offset = (500000.0, 4500000.0, 0.0) if utm else (0.0, 0.0, 0.0)
    V, F, _ = S.jittered_mesh(S.gaussian_hill(2.0, 5.0), 6.0, spacing, seed=seed, offset=offset)
    b = build_buckets(V, F)
    rng = np.random.default_rng(seed)
    lo, hi = V[:, :2].min(axis=0), V[:, :2].max(axis=0)
    points = np.vstack([rng.uniform(lo, hi, (40, 2)), V[:10, :2]])  # vertices themselves: on edges
    for p in points:
        truth = containing_triangles_brute_force(V, F, p)
        col, row = np.floor((p - b.origin) / b.cell).astype(int)
        col, row = min(col, b.shape[1] - 1), min(row, b.shape[0] - 1)
        k = row * b.shape[1] + col
        candidates = set(b.face[b.start[k]:b.start[k + 1]].tolist())
        assert truth <= candidates
