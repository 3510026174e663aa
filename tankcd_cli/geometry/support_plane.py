"""The lowest plane over a point that no sample point rises above.

Given points (u_k, v_k, z_k), find the plane z = a + b u + c v with
a + b u_k + c v_k >= z_k for every k and the smallest a (its height over the
origin): a three-variable linear programme whose optimum is the facet of the
points' upper convex hull above the origin. This is how a rigid hull rests on
the ground under it (the reference pose of docs/formats.md), and it is also how the
six-point matcher picks its three supporting points.

``support_plane`` walks the upper hull towards the origin (a simplex method on
three variables: each pivot rotates the plane about two tight points until a
third touches); ``support_plane_brute_force`` tries every triple and is the
oracle the tests compare it with.

Ties (the origin exactly above an edge between two facets: a tank balanced on
a knife-edge crest) are broken by the middle of the optimal planes, so the
answer is deterministic and symmetric.

``support_plane`` and ``support_planes_fixed`` are compiled ahead of time
(Cython, ``_support_plane.pyx``; other kernels cimport the walk as the C
function ``support_plane_c``); the brute force is plain numpy.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.geometry._support_plane import MAX_PIVOTS, support_plane, support_planes_fixed  # noqa: F401


def support_plane_brute_force(u: np.ndarray, v: np.ndarray, z: np.ndarray) -> float:
    """Height over the origin of the upper hull: the highest interpolation, at the
    origin, of any triangle or segment of points containing it (O(n^3) oracle: every
    point, pair and triple tried, in blocks of triples so that memory stays bounded)."""
    u, v, z = (np.asarray(a, dtype=np.float64) for a in (u, v, z))
    n = len(u)
    best = -np.inf
    at = (np.abs(u) < 1e-12) & (np.abs(v) < 1e-12)
    if at.any():
        best = float(z[at].max())
    i, j = np.triu_indices(n, 1)
    # a segment through the origin
    du, dv = u[j] - u[i], v[j] - v[i]
    cross = u[i] * dv - v[i] * du
    length = du * du + dv * dv
    seg = (np.abs(cross) < 1e-12) & (length > 0)
    if seg.any():
        t = -(u[i][seg] * du[seg] + v[i][seg] * dv[seg]) / length[seg]
        inside = (t >= 0) & (t <= 1)
        if inside.any():
            best = max(best, float((z[i][seg] + t * (z[j][seg] - z[i][seg]))[inside].max()))
    # a triangle containing the origin: its barycentric weights of the origin, all >= 0
    triples = np.array([(a, b, c) for a in range(n) for b in range(a + 1, n) for c in range(b + 1, n)],
                       dtype=np.int64).reshape(-1, 3)
    for lo in range(0, len(triples), 1 << 16):
        tri = triples[lo:lo + (1 << 16)]
        M = np.stack([u[tri], v[tri], np.ones(tri.shape)], axis=1)  # (T, 3, 3): columns the points
        ok = np.abs(np.linalg.det(M)) >= 1e-12
        if not ok.any():
            continue
        lam = np.linalg.solve(M[ok], np.broadcast_to([0.0, 0.0, 1.0], (int(ok.sum()), 3))[..., None])[..., 0]
        inside = (lam >= -1e-12).all(axis=1)
        if inside.any():
            best = max(best, float(np.einsum("ti,ti->t", lam[inside], z[tri[ok][inside]]).max()))
    return best
