"""numba kernels for the per-face and per-vertex passes that numpy cannot do in one sweep.

Each kernel has a numpy twin in ``curvature.py`` (the oracle); the tests make
them agree. Importing this module imports numba (about 0.2 s), so callers
use it only for meshes large enough to repay that (``FAST_MIN_VERTICES``).
Compiled code is cached on disk (``cache=True``): the first run on a machine
compiles for a few seconds, later runs load in milliseconds.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def cotan_accumulate(V, F):  # pragma: no cover - compiled
    """One pass over the faces: K = sum (cot a + cot b)(X_j - X_i), the upward
    area-weighted normal sum and the mixed Voronoi area at each vertex.

    V : (n, 3) float64; F : (m, 3) int64
    Returns K (n, 3), normal sum (n, 3), mixed area (n,).
    """
    n = V.shape[0]
    K = np.zeros((n, 3))
    N = np.zeros((n, 3))
    A = np.zeros(n)
    e = np.empty((3, 3))
    cot = np.empty(3)
    len2 = np.empty(3)
    for f in range(F.shape[0]):
        i = F[f, 0]
        j = F[f, 1]
        k = F[f, 2]
        idx = (i, j, k)
        for c in range(3):
            e[0, c] = V[k, c] - V[j, c]  # opposite corner 0
            e[1, c] = V[i, c] - V[k, c]  # opposite corner 1
            e[2, c] = V[j, c] - V[i, c]  # opposite corner 2
        # normal = (X_j - X_i) x (X_k - X_i) = e2 x (-e1)
        nx = -(e[2, 1] * e[1, 2] - e[2, 2] * e[1, 1])
        ny = -(e[2, 2] * e[1, 0] - e[2, 0] * e[1, 2])
        nz = -(e[2, 0] * e[1, 1] - e[2, 1] * e[1, 0])
        if nz < 0:
            nx, ny, nz = -nx, -ny, -nz
        dbl = np.sqrt(nx * nx + ny * ny + nz * nz)
        for a in range(3):
            b = (a + 1) % 3
            len2[a] = e[a, 0] * e[a, 0] + e[a, 1] * e[a, 1] + e[a, 2] * e[a, 2]
            # cot at corner a = -(e[a+2] . e[a+1]) / |n|
            d = (a + 2) % 3
            cot[a] = -(e[d, 0] * e[b, 0] + e[d, 1] * e[b, 1] + e[d, 2] * e[b, 2]) / dbl
        for a in range(3):
            p = idx[(a + 1) % 3]
            q = idx[(a + 2) % 3]
            for c in range(3):
                w = cot[a] * e[a, c]
                K[p, c] += w
                K[q, c] -= w
            v = idx[a]
            N[v, 0] += nx
            N[v, 1] += ny
            N[v, 2] += nz
        obtuse = cot[0] < 0 or cot[1] < 0 or cot[2] < 0
        area = dbl / 2.0
        for a in range(3):
            v = idx[a]
            if obtuse:
                A[v] += area / 2.0 if cot[a] < 0 else area / 4.0
            else:
                b = (a + 1) % 3
                d = (a + 2) % 3
                A[v] += (len2[d] * cot[d] + len2[b] * cot[b]) / 8.0
    return K, N, A


@njit(cache=True)
def vertex_face_csr(F, n):  # pragma: no cover - compiled
    """Faces around each vertex: vertex v has faces face[start[v]:start[v + 1]]."""
    start = np.zeros(n + 1, np.int64)
    for f in range(F.shape[0]):
        for a in range(3):
            start[F[f, a] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    face = np.empty(start[n], np.int64)
    for f in range(F.shape[0]):
        for a in range(3):
            v = F[f, a]
            face[fill[v]] = f
            fill[v] += 1
    return start, face


@njit(cache=True)
def boundary_flags(F, n, start, face):  # pragma: no cover - compiled
    """Per vertex: on a boundary edge (a ring neighbour seen once) or a
    non-manifold edge (seen more than twice). Isolated vertices count as boundary."""
    boundary = np.zeros(n, np.bool_)
    nonmanifold = np.zeros(n, np.bool_)
    widest = 0
    for v in range(n):
        widest = max(widest, start[v + 1] - start[v])
    other = np.empty(2 * widest + 1, np.int64)  # one buffer, reused: no allocation per vertex
    for v in range(n):
        if start[v + 1] == start[v]:
            boundary[v] = True
            continue
        t = 0
        for s in range(start[v], start[v + 1]):
            f = face[s]
            for a in range(3):
                u = F[f, a]
                if u != v:
                    # insertion sort: the ring holds a dozen entries or so
                    p = t
                    while p > 0 and other[p - 1] > u:
                        other[p] = other[p - 1]
                        p -= 1
                    other[p] = u
                    t += 1
        run = 1
        for s in range(1, t + 1):
            if s < t and other[s] == other[s - 1]:
                run += 1
            else:
                if run == 1:
                    boundary[v] = True
                elif run > 2:
                    nonmanifold[v] = True
                run = 1
    return boundary, nonmanifold


@njit(cache=True)
def grow_rings(F, start, face, seed, rings):  # pragma: no cover - compiled
    """Vertices within ``rings`` edge hops of a seed vertex (mask)."""
    mark = seed.copy()
    frontier = np.flatnonzero(seed)
    for _ in range(rings):
        nxt = []
        for v in frontier:
            for s in range(start[v], start[v + 1]):
                f = face[s]
                for a in range(3):
                    u = F[f, a]
                    if not mark[u]:
                        mark[u] = True
                        nxt.append(u)
        frontier = np.array(nxt, dtype=np.int64)
        if frontier.size == 0:
            break
    return mark


@njit(cache=True)
def open_vertex_flags(F, n, rings):  # pragma: no cover - compiled
    """Boundary and non-manifold flags, and the vertices within ``rings`` hops of either."""
    start, face = vertex_face_csr(F, n)
    boundary, nonmanifold = boundary_flags(F, n, start, face)
    near = grow_rings(F, start, face, boundary | nonmanifold, rings)
    return boundary, nonmanifold, near
