"""Tandem depth-first traversal of two trees, batched over poses (compiled).

Tree A moves (a vehicle, its triangles in its own frame, placed by x -> R x + t
at each pose); tree B is static (an obstacle in the world). Each pose walks
the two trees together from the roots, depth first as in the paper: a pair of
nodes whose volumes are disjoint is dropped, otherwise the larger node is
opened, and at two leaves their triangles are tested exactly. The volume test
of a pair is the AABB test when either node lies in its tree's AABB levels,
the k-DOP test below. A's volume at a pose is the conservative moved k-DOP of
``geometry.kdop``. Poses run in parallel threads ("same-layer subtasks in
parallel"); within a pose the walk is sequential, so "first contact" can stop
at the first hit.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from tankcd_cli.geometry.triangles import tri_tri

FIRST, ALL = 0, 1


@njit(cache=True)
def _walk(R, tv, f, g, shift, a_tri, a_idx, a_left, a_right, a_start, a_count, a_depth, a_levels, a_centre, a_half,
          a_size, b_tri, b_idx, b_lo, b_hi, b_left, b_right, b_start, b_count, b_depth, b_levels, b_size,
          mode, pairs, points, stack, tol):  # pragma: no cover - compiled
    K = f.shape[0]
    T = g.shape[0]
    node_tests = 0
    tri_tests = 0
    found = 0
    cap = pairs.shape[0]
    P = np.empty((3, 3))
    out = np.empty(3)
    scratch = np.empty((6, 3))
    sp = 0
    stack[0, 0] = 0
    stack[0, 1] = 0
    sp = 1
    while sp > 0:
        sp -= 1
        a = stack[sp, 0]
        b = stack[sp, 1]
        node_tests += 1
        aabb = a_depth[a] < a_levels or b_depth[b] < b_levels
        nd = 3 if aabb else K
        nt = 1 if aabb else T
        disjoint = False
        for i in range(nd):
            best_lo = -np.inf
            best_hi = np.inf
            for t in range(nt):
                c = f[i, 0] * a_centre[a, t, 0] + f[i, 1] * a_centre[a, t, 1] + f[i, 2] * a_centre[a, t, 2]
                r = (abs(g[t, i, 0]) * a_half[a, t, 0] + abs(g[t, i, 1]) * a_half[a, t, 1]
                     + abs(g[t, i, 2]) * a_half[a, t, 2])
                if c - r > best_lo:
                    best_lo = c - r
                if c + r < best_hi:
                    best_hi = c + r
            if best_lo + shift[i] > b_hi[b, i] + tol or best_hi + shift[i] < b_lo[b, i] - tol:
                disjoint = True
                break
        if disjoint:
            continue
        a_leaf = a_left[a] < 0
        b_leaf = b_left[b] < 0
        if a_leaf and b_leaf:
            for ta in range(a_start[a], a_start[a] + a_count[a]):
                for v in range(3):
                    for m in range(3):
                        P[v, m] = (R[m, 0] * a_tri[ta, v, 0] + R[m, 1] * a_tri[ta, v, 1]
                                   + R[m, 2] * a_tri[ta, v, 2] + tv[m])
                for tb in range(b_start[b], b_start[b] + b_count[b]):
                    tri_tests += 1
                    if tri_tri(P, b_tri[tb], out, scratch):
                        if found < cap:
                            pairs[found, 0] = a_idx[ta]
                            pairs[found, 1] = b_idx[tb]
                            points[found, 0] = out[0]
                            points[found, 1] = out[1]
                            points[found, 2] = out[2]
                        found += 1
                        if mode == FIRST:
                            return found, node_tests, tri_tests
            continue
        if b_leaf or (not a_leaf and a_size[a] >= b_size[b]):
            stack[sp, 0] = a_left[a]
            stack[sp, 1] = b
            stack[sp + 1, 0] = a_right[a]
            stack[sp + 1, 1] = b
        else:
            stack[sp, 0] = a
            stack[sp, 1] = b_left[b]
            stack[sp + 1, 0] = a
            stack[sp + 1, 1] = b_right[b]
        sp += 2
    return found, node_tests, tri_tests


@njit(cache=True, parallel=True)
def collide_batch(R, tv, D, W, a_tri, a_idx, a_left, a_right, a_start, a_count, a_depth, a_levels, a_centre, a_half,
                  a_size, b_tri, b_idx, b_lo, b_hi, b_left, b_right, b_start, b_count, b_depth, b_levels, b_size,
                  mode, max_contacts):  # pragma: no cover - compiled
    """Walk A at every pose (R (N, 3, 3), t (N, 3)) against B.

    Returns contacts found per pose (N,) (all of them in mode ALL, 0 or 1 in
    FIRST), the first ``max_contacts`` pairs (N, c, 2) of input triangle
    indices and their contact points (N, c, 3), and the node-pair and
    triangle-pair tests made (N,).
    """
    n = R.shape[0]
    K = D.shape[0]
    T = W.shape[0]
    found = np.zeros(n, np.int64)
    node_tests = np.zeros(n, np.int64)
    tri_tests = np.zeros(n, np.int64)
    pairs = np.full((n, max(max_contacts, 1), 2), -1, np.int64)
    points = np.full((n, max(max_contacts, 1), 3), np.nan)
    depth = a_depth.max() + b_depth.max() + 4
    reach = 0.0  # the largest coordinate of either tree's bounds
    for i in range(3):
        reach = max(reach, abs(a_centre[0, 0, i]) + abs(a_half[0, 0, i]), abs(b_lo[0, i]), abs(b_hi[0, i]))
    for p in prange(n):
        f = np.empty((K, 3))
        for i in range(K):
            for j in range(3):
                f[i, j] = D[i, 0] * R[p, 0, j] + D[i, 1] * R[p, 1, j] + D[i, 2] * R[p, 2, j]
        g = np.empty((T, K, 3))
        for t in range(T):
            for i in range(K):
                for j in range(3):
                    g[t, i, j] = f[i, 0] * W[t, 0, j] + f[i, 1] * W[t, 1, j] + f[i, 2] * W[t, 2, j]
        shift = np.empty(K)
        for i in range(K):
            shift[i] = D[i, 0] * tv[p, 0] + D[i, 1] * tv[p, 1] + D[i, 2] * tv[p, 2]
        stack = np.empty((2 * depth + 2, 2), np.int64)
        # volumes are compared with a margin of round-off, so that exactly touching shapes are never
        # dropped before their triangles (which count touching as contact) are tested
        scale = abs(tv[p, 0]) + abs(tv[p, 1]) + abs(tv[p, 2]) + reach
        found[p], node_tests[p], tri_tests[p] = _walk(
            R[p], tv[p], f, g, shift, a_tri, a_idx, a_left, a_right, a_start, a_count, a_depth, a_levels, a_centre,
            a_half, a_size, b_tri, b_idx, b_lo, b_hi, b_left, b_right, b_start, b_count, b_depth, b_levels, b_size,
            mode, pairs[p], points[p], stack, 1e-12 * scale)
    return found, pairs, points, node_tests, tri_tests


@njit(cache=True, parallel=True)
def brute_force_batch(R, tv, a_tri, b_tri, mode):  # pragma: no cover - compiled
    """Every triangle pair at every pose: contacts found (N,) (the oracle of the trees)."""
    n = R.shape[0]
    found = np.zeros(n, np.int64)
    for p in prange(n):
        P = np.empty((3, 3))
        out = np.empty(3)
        for ta in range(a_tri.shape[0]):
            for v in range(3):
                for m in range(3):
                    P[v, m] = (R[p, m, 0] * a_tri[ta, v, 0] + R[p, m, 1] * a_tri[ta, v, 1]
                               + R[p, m, 2] * a_tri[ta, v, 2] + tv[p, m])
            for tb in range(b_tri.shape[0]):
                if tri_tri(P, b_tri[tb], out):
                    found[p] += 1
                    if mode == FIRST:
                        break
            if mode == FIRST and found[p]:
                break
    return found
