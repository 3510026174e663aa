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
    origin, of any triangle or segment of points containing it (O(n^3) oracle)."""
    best = -np.inf
    n = len(u)
    for i in range(n):
        if abs(u[i]) < 1e-12 and abs(v[i]) < 1e-12:
            best = max(best, z[i])
        for j in range(i + 1, n):
            # a segment through the origin
            du, dv = u[j] - u[i], v[j] - v[i]
            cross = u[i] * dv - v[i] * du
            if abs(cross) < 1e-12 and (du * du + dv * dv) > 0:
                t = -(u[i] * du + v[i] * dv) / (du * du + dv * dv)
                if 0 <= t <= 1:
                    best = max(best, z[i] + t * (z[j] - z[i]))
            for k in range(j + 1, n):
                M = np.array([[u[i], u[j], u[k]], [v[i], v[j], v[k]], [1.0, 1.0, 1.0]])
                if abs(np.linalg.det(M)) < 1e-12:
                    continue
                lam = np.linalg.solve(M, [0.0, 0.0, 1.0])
                if (lam >= -1e-12).all():
                    best = max(best, float(lam @ [z[i], z[j], z[k]]))
    return best
