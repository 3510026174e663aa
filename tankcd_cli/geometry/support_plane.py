"""The lowest plane over a point that no sample point rises above.

Given points (u_k, v_k, z_k), find the plane z = a + b u + c v with
a + b u_k + c v_k >= z_k for every k and the smallest a (its height over the
origin): a three-variable linear programme whose optimum is the facet of the
points' upper convex hull above the origin. This is how a rigid hull rests on
the ground under it (the contract's reference pose), and it is also how the
six-point matcher picks its three supporting points.

``support_plane`` walks the upper hull towards the origin (a simplex method on
three variables: each pivot rotates the plane about two tight points until a
third touches); ``support_plane_brute_force`` tries every triple and is the
oracle the tests compare it with.

Ties (the origin exactly above an edge between two facets: a tank balanced on
a knife-edge crest) are broken by the middle of the optimal planes, so the
answer is deterministic and symmetric.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

MAX_PIVOTS = 200


@njit(cache=True)
def support_plane(u, v, z, count, eps):  # pragma: no cover - compiled
    """Lowest supporting plane over the origin of the first ``count`` points.

    Returns (a, b, c, status): status 0 optimal, 1 no points, 2 not converged
    (the origin outside the points' hull, or cycling): callers fall back.
    ``eps`` is the length below which xy distances count as zero.
    """
    if count == 0:
        return np.nan, np.nan, np.nan, 1
    p = 0
    for k in range(1, count):
        if z[k] > z[p]:
            p = k
    zp = z[p]
    up = u[p]
    vp = v[p]
    r = np.sqrt(up * up + vp * vp)
    b = 0.0
    c = 0.0
    if r <= eps:
        return zp, 0.0, 0.0, 0  # the highest point is over the origin: a level plane through it
    # rotate the level plane about p, lowering the origin side, until a second point touches
    du = up / r
    dv = vp / r
    best_t = np.inf
    best_d = 0.0
    q = -1
    for k in range(count):
        d = (u[k] - up) * du + (v[k] - vp) * dv
        if d < -eps:
            t = (z[k] - zp) / d  # >= 0
            if t < best_t - 1e-15 or (t <= best_t + 1e-15 and d < best_d):
                best_t = t
                best_d = d
                q = k
    if q < 0:
        return np.nan, np.nan, np.nan, 2
    b = best_t * du
    c = best_t * dv
    for _ in range(MAX_PIVOTS):
        # rotate about the line p-q
        eu = u[q] - up
        ev = v[q] - vp
        el = np.sqrt(eu * eu + ev * ev)
        mu = -ev / el
        mv = eu / el
        side = -(mu * up + mv * vp)  # signed distance of the origin from the line along m
        if abs(side) <= eps:
            # the origin is on the line: every plane through p and q between the two
            # neighbouring facets is optimal; take the middle one
            s_pos = np.inf
            s_neg = np.inf
            for k in range(count):
                d = mu * (u[k] - up) + mv * (v[k] - vp)
                slack = zp + b * (u[k] - up) + c * (v[k] - vp) - z[k]
                if d < -eps:
                    s_pos = min(s_pos, slack / -d)
                elif d > eps:
                    s_neg = min(s_neg, slack / d)
            s = 0.0
            if np.isfinite(s_pos) and np.isfinite(s_neg):
                s = 0.5 * (s_pos - s_neg)
            b += s * mu
            c += s * mv
            return zp - b * up - c * vp, b, c, 0
        if side < 0:
            mu = -mu
            mv = -mv  # m points from the line towards the origin
        best_s = np.inf
        best_d = 0.0
        w = -1
        for k in range(count):
            d = mu * (u[k] - up) + mv * (v[k] - vp)
            if d > eps:  # on the origin's side: the plane comes down towards it
                slack = zp + b * (u[k] - up) + c * (v[k] - vp) - z[k]
                if slack < 0.0:
                    slack = 0.0
                s = slack / d
                if s < best_s - 1e-15 or (s <= best_s + 1e-15 and d > best_d):
                    best_s = s
                    best_d = d
                    w = k
        if w < 0:
            return np.nan, np.nan, np.nan, 2
        # rotating by s lowers the origin side: plane gradient moves against m
        b -= best_s * mu
        c -= best_s * mv
        # is the origin inside triangle p q w?
        ax = u[p]
        ay = v[p]
        bx = u[q] - ax
        by = v[q] - ay
        cx = u[w] - ax
        cy = v[w] - ay
        det = bx * cy - by * cx
        ox = -ax
        oy = -ay
        lq = (ox * cy - oy * cx) / det
        lw = (bx * oy - by * ox) / det
        lp = 1.0 - lq - lw
        tol = -1e-12
        if lp >= tol and lq >= tol and lw >= tol:
            return zp - b * up - c * vp, b, c, 0
        # keep the edge that faces the origin: drop the vertex with the most negative weight
        if lp <= lq:
            p = w  # drop p: keep q and w
        else:
            q = w  # drop q: keep p and w
        zp = z[p]
        up = u[p]
        vp = v[p]
    return np.nan, np.nan, np.nan, 2


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


@njit(cache=True, parallel=True)
def support_planes_fixed(u, v, z, eps):  # pragma: no cover - compiled
    """``support_plane`` for many poses sharing the same point layout.

    u, v : (k,) point positions in the heading frame; z : (N, k) heights.
    Returns planes (N, 3) and status (N,).
    """
    n = z.shape[0]
    out = np.empty((n, 3))
    status = np.empty(n, np.int64)
    for i in prange(n):
        a, b, c, st = support_plane(u, v, z[i], u.shape[0], eps)
        out[i, 0] = a
        out[i, 1] = b
        out[i, 2] = c
        status[i] = st
    return out, status
