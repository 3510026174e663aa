"""Finite cylinders (flat caps): the exact intersection test and the paper's two-plane projection test.

Both are answered by one GJK distance routine (Gilbert, Johnson and Keerthi
1988) on the Minkowski difference of two convex sets, through their support
mappings. A cylinder with centre c, unit axis a, half-length h and radius r
has the support point, in direction d,

    c + sign(d . a) h a + r (d - (d . a) a) / |d - (d . a) a|.

``cylinders_intersect`` runs GJK in 3D. GJK keeps, at every step, an upper
bound |v| on the distance (the closest point of the current simplex) and a
lower bound v . w / |v| (the separating plane through the newest support
point w); it stops when they are within ``tol`` of each other, so the answer
"touching or intersecting" (distance <= tol) versus "apart" is certain up to
``tol`` (1e-9 m by default). Touching counts as intersecting.

``projections_overlap`` is the paper's method: the two cylinders are
projected onto a plane (the vehicle's xoy or yoz) and their exact shadows
(the convex hull of the two projected caps: rectangles with elliptic ends,
rectangles, discs) are tested for overlap, by the same GJK on support
mappings projected into the plane. The paper reports a collision unless the
shadows are disjoint in one of the planes: conservative (a real collision
overlaps in every projection), never missing one.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

TOL = 1e-9
MAX_ITER = 128


@njit(cache=True, inline="always")
def _support(c, a, h, r, dx, dy, dz, nx, ny, nz, out, k):  # pragma: no cover - compiled
    """Support point of cylinder (c, a, h, r) along d, projected on the plane of normal n (n = 0: none)."""
    da = dx * a[0] + dy * a[1] + dz * a[2]
    s = h if da >= 0 else -h
    wx = dx - da * a[0]
    wy = dy - da * a[1]
    wz = dz - da * a[2]
    wn = np.sqrt(wx * wx + wy * wy + wz * wz)
    px = c[0] + s * a[0]
    py = c[1] + s * a[1]
    pz = c[2] + s * a[2]
    if wn > 1e-300:
        px += r * wx / wn
        py += r * wy / wn
        pz += r * wz / wn
    pn = px * nx + py * ny + pz * nz
    out[k, 0] = px - pn * nx
    out[k, 1] = py - pn * ny
    out[k, 2] = pz - pn * nz


@njit(cache=True)
def _closest_on_simplex(S, m, lam, best):  # pragma: no cover - compiled
    """Closest point to the origin of the simplex S[:m] (m <= 4), trying every face.

    Returns (point x, y, z, the kept vertices' mask bits); lam receives weights.
    """
    best_d = np.inf
    bx = by = bz = 0.0
    keep = 0
    for mask in range(1, 1 << m):
        idx = np.empty(4, np.int64)
        q = 0
        for i in range(m):
            if mask & (1 << i):
                idx[q] = i
                q += 1
        # minimise |sum l_i S_i| with sum l_i = 1: solve on the differences from the first vertex
        p0 = S[idx[0]]
        if q == 1:
            x, y, z = p0[0], p0[1], p0[2]
            w = np.array([1.0, 0.0, 0.0, 0.0])
        else:
            G = np.zeros((q - 1, q - 1))
            rhs = np.zeros(q - 1)
            for i in range(1, q):
                ei = S[idx[i]] - p0
                rhs[i - 1] = -(ei[0] * p0[0] + ei[1] * p0[1] + ei[2] * p0[2])
                for j in range(1, q):
                    ej = S[idx[j]] - p0
                    G[i - 1, j - 1] = ei[0] * ej[0] + ei[1] * ej[1] + ei[2] * ej[2]
            if abs(np.linalg.det(G)) < 1e-24 * max(1.0, G.max() ** (q - 1)):
                continue  # a degenerate face: its points are covered by smaller ones
            t = np.linalg.solve(G, rhs)
            w = np.zeros(4)
            w[0] = 1.0 - t.sum()
            for i in range(q - 1):
                w[i + 1] = t[i]
            ok = True
            for i in range(q):
                if w[i] < -1e-12:
                    ok = False
            if not ok:
                continue
            x = y = z = 0.0
            for i in range(q):
                x += w[i] * S[idx[i], 0]
                y += w[i] * S[idx[i], 1]
                z += w[i] * S[idx[i], 2]
        d = x * x + y * y + z * z
        if d < best_d - 1e-30 or (d <= best_d and q < 4):
            best_d = d
            bx, by, bz = x, y, z
            keep = mask
    return bx, by, bz, keep


@njit(cache=True)
def gjk_distance(cA, aA, hA, rA, cB, aB, hB, rB, nx, ny, nz, tol, stop_apart=True):  # pragma: no cover - compiled
    """Distance between two cylinders (or their projections on the plane of normal n), to ``tol``.

    With ``stop_apart`` it returns as soon as a lower bound exceeds ``tol`` (that bound, not the
    distance): enough to decide contact, and much quicker for shapes far apart.
    """
    S = np.empty((4, 3))
    tmp = np.empty((2, 3))
    lam = np.empty(4)
    # start from the direction between the centres (projected)
    vx = cA[0] - cB[0]
    vy = cA[1] - cB[1]
    vz = cA[2] - cB[2]
    vn = vx * nx + vy * ny + vz * nz
    vx -= vn * nx
    vy -= vn * ny
    vz -= vn * nz
    if vx * vx + vy * vy + vz * vz == 0.0:
        vx, vy, vz = (1.0, 0.0, 0.0) if abs(nx) < 0.9 else (0.0, 1.0, 0.0)
    m = 0
    for _ in range(MAX_ITER):
        _support(cA, aA, hA, rA, -vx, -vy, -vz, nx, ny, nz, tmp, 0)
        _support(cB, aB, hB, rB, vx, vy, vz, nx, ny, nz, tmp, 1)
        wx = tmp[0, 0] - tmp[1, 0]
        wy = tmp[0, 1] - tmp[1, 1]
        wz = tmp[0, 2] - tmp[1, 2]
        vv = vx * vx + vy * vy + vz * vz
        vnorm = np.sqrt(vv)
        # lower bound on the distance: the plane orthogonal to v through w
        if stop_apart and vnorm > 0 and (vx * wx + vy * wy + vz * wz) / vnorm > tol:
            return (vx * wx + vy * wy + vz * wz) / vnorm  # separated by more than tol
        if vnorm > 0 and vnorm - (vx * wx + vy * wy + vz * wz) / vnorm <= tol:
            return vnorm  # upper and lower bounds meet
        S[m, 0] = wx
        S[m, 1] = wy
        S[m, 2] = wz
        m += 1
        px, py, pz, keep = _closest_on_simplex(S, m, lam, 0)
        q = 0
        for i in range(m):
            if keep & (1 << i):
                S[q] = S[i]
                q += 1
        m = q
        vx, vy, vz = px, py, pz
        if vx * vx + vy * vy + vz * vz <= tol * tol or m == 4:
            return 0.0
    return np.sqrt(vx * vx + vy * vy + vz * vz)


@njit(cache=True, parallel=True)
def cylinders_distance_batch(cA, aA, hA, rA, cB, aB, hB, rB, normal, tol):  # pragma: no cover - compiled
    """Distances (N,) between cylinder A_i (centres (N, 3), axes (N, 3), h, r) and a fixed cylinder B,
    in 3D (normal = 0) or between their shadows on the plane of unit ``normal``."""
    n = cA.shape[0]
    out = np.empty(n)
    for i in prange(n):
        out[i] = gjk_distance(cA[i], aA[i], hA, rA, cB, aB, hB, rB, normal[0], normal[1], normal[2], tol)
    return out


def cylinders_intersect(cA, aA, hA, rA, cB, aB, hB, rB, tol: float = TOL) -> np.ndarray:
    """Exact test (N,) bool: cylinders A_i (centres (N, 3), unit axes (N, 3)) against cylinder B."""
    cA, aA = np.ascontiguousarray(cA, float).reshape(-1, 3), np.ascontiguousarray(aA, float).reshape(-1, 3)
    d = cylinders_distance_batch(cA, aA, float(hA), float(rA), np.asarray(cB, float), np.asarray(aB, float),
                                 float(hB), float(rB), np.zeros(3), tol)
    return d <= tol


def projections_overlap(cA, aA, hA, rA, cB, aB, hB, rB, normals=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
                        tol: float = TOL) -> np.ndarray:
    """The paper's test (N,) bool: a collision unless the shadows are disjoint on one of the planes
    (default: xoy, normal z, and yoz, normal x)."""
    cA, aA = np.ascontiguousarray(cA, float).reshape(-1, 3), np.ascontiguousarray(aA, float).reshape(-1, 3)
    hit = np.ones(len(cA), dtype=bool)
    for nrm in normals:
        d = cylinders_distance_batch(cA, aA, float(hA), float(rA), np.asarray(cB, float), np.asarray(aB, float),
                                     float(hB), float(rB), np.asarray(nrm, float), tol)
        hit &= d <= tol
    return hit
