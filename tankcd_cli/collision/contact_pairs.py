"""The triangle pairs of a first contact between two placed bodies (``collision.vehicles.contact_centres``):
for each contact, every pair of triangles whose boxes come within a reach of each other, after each
side is shrunk to the box of the other's near triangles; and the 15 feature pairs (vertex against
triangle, edge against edge) of each such pair. The compiled kernels, and their numpy twins."""

from __future__ import annotations

import numpy as np

from tankcd_cli.collision._contact_pairs import near_triangle_pairs, triangle_pair_features

__all__ = ["near_triangle_pairs", "near_triangle_pairs_numpy", "plane_separated", "triangle_pair_features",
           "triangle_pair_features_numpy"]


def near_triangle_pairs_numpy(A: np.ndarray, B: np.ndarray, reach: float, rounds: int = 3, planes: bool = False):
    """``near_triangle_pairs`` in numpy (placed triangles (K, m, 3, 3) in; owner, ia, ib out): the
    compiled kernel's twin, which the tests hold it to."""
    alo, ahi, blo, bhi = A.min(axis=2), A.max(axis=2), B.min(axis=2), B.max(axis=2)
    owners, ias, ibs = [], [], []
    for i in range(len(alo)):
        al, ah, bl, bh = alo[i], ahi[i], blo[i], bhi[i]
        near_a, near_b = np.arange(len(al)), np.arange(len(bl))
        for _ in range(rounds):  # each side's triangles in the box of the other's near ones
            lo, hi = bl[near_b].min(axis=0, initial=np.inf), bh[near_b].max(axis=0, initial=-np.inf)
            near_a = near_a[((al[near_a] <= hi + reach) & (ah[near_a] >= lo - reach)).all(axis=1)]
            lo, hi = al[near_a].min(axis=0, initial=np.inf), ah[near_a].max(axis=0, initial=-np.inf)
            near_b = near_b[((bl[near_b] <= hi + reach) & (bh[near_b] >= lo - reach)).all(axis=1)]
        close = ((al[near_a, None] <= bh[None, near_b] + reach) & (ah[near_a, None] >= bl[None, near_b] - reach)).all(axis=2)
        a, b = np.nonzero(close)
        owners.append(np.full(len(a), i, dtype=np.int64))
        ias.append(near_a[a].astype(np.int64))
        ibs.append(near_b[b].astype(np.int64))
    if not owners:
        z = np.zeros(0, dtype=np.int64)
        return z, z.copy(), z.copy()
    owner, ia, ib = np.concatenate(owners), np.concatenate(ias), np.concatenate(ibs)
    if planes:
        keep = ~plane_separated(A[owner, ia], B[owner, ib], reach)
        owner, ia, ib = owner[keep], ia[keep], ib[keep]
    return owner, ia, ib


def plane_separated(P: np.ndarray, Q: np.ndarray, reach: float) -> np.ndarray:
    """(J,) bool: the pairs (P[j], Q[j]) (J, 3, 3) one of whose triangles lies wholly farther than
    ``reach`` beyond the other's plane, on one side (a lower bound of their distance; a triangle of
    no area has no plane)."""
    apart = np.zeros(len(P), bool)
    for X, Y in ((P, Q), (Q, P)):
        n = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
        size = np.linalg.norm(n, axis=1)
        ok = size > 0
        n[ok] /= size[ok, None]
        side = np.einsum("jvi,ji->jv", Y - X[:, :1], n)
        apart |= ok & ((side > reach).all(axis=1) | (side < -reach).all(axis=1))
    return apart


def _dot(x, y):
    """Row-wise dot products (J,) of (J, 3) arrays, summed in the kernel's order (einsum's is its own)."""
    return x[:, 0] * y[:, 0] + x[:, 1] * y[:, 1] + x[:, 2] * y[:, 2]


def _closest_on_triangle(p, a, b, c):
    """The closest points (J, 3) of triangles abc to points p (Ericson, Real-Time Collision Detection 5.1.5),
    vectorized."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    bp = p - b
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    cp = p - c
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = 1.0 / (va + vb + vc)
        v, w = vb * denom, vc * denom
        out = a + ab * v[:, None] + ac * w[:, None]  # inside the face
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    cases = [
        ((d1 <= 0) & (d2 <= 0), a),
        ((d3 >= 0) & (d4 <= d3), b),
        ((d6 >= 0) & (d5 <= d6), c),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * t_ab[:, None]),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * t_ac[:, None]),
        ((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), b + (c - b) * t_bc[:, None]),
    ]
    done = np.zeros(len(p), bool)
    for mask, value in cases:
        m = mask & ~done
        out[m] = value[m]
        done |= m
    return out


def _closest_on_segments(p1, q1, p2, q2):
    """The closest points (J, 3), (J, 3) of segments p1q1 and p2q2 (Ericson 5.1.9), vectorized."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e = _dot(d1, d1), _dot(d2, d2)
    f, c = _dot(d2, r), _dot(d1, r)
    b = _dot(d1, d2)
    tiny = 1e-300
    with np.errstate(divide="ignore", invalid="ignore"):
        den = a * e - b * b
        s = np.where(den > tiny, np.clip((b * f - c * e) / den, 0, 1), 0.0)
        s = np.where(a > tiny, s, 0.0)
        t = np.where(e > tiny, (b * s + f) / e, 0.0)
        s = np.where(t < 0, np.where(a > tiny, np.clip(-c / a, 0, 1), 0.0), s)
        s = np.where(t > 1, np.where(a > tiny, np.clip((b - c) / a, 0, 1), 0.0), s)
    t = np.clip(t, 0, 1)
    return p1 + d1 * s[:, None], p2 + d2 * t[:, None]


def triangle_pair_features_numpy(P: np.ndarray, Q: np.ndarray):
    """The 15 feature pairs of triangle pairs P[j], Q[j] (J, 3, 3): each one's vertices against the other
    triangle (6) and the nine edge pairs, as distances (J, 15) and their closest points (J, 15, 3) twice.
    The least of a pair's 15 is its distance where the triangles do not cross (where they do, at most
    the crossing's depth). The compiled kernel's twin, which the tests hold it to, bit for bit."""
    cand = []
    for k in range(3):
        cand.append((P[:, k], _closest_on_triangle(P[:, k], Q[:, 0], Q[:, 1], Q[:, 2])))
        cand.append((_closest_on_triangle(Q[:, k], P[:, 0], P[:, 1], P[:, 2]), Q[:, k]))
    for i in range(3):
        for j in range(3):
            cand.append(_closest_on_segments(P[:, i], P[:, (i + 1) % 3], Q[:, j], Q[:, (j + 1) % 3]))
    cp = np.stack([c[0] for c in cand], axis=1)
    cq = np.stack([c[1] for c in cand], axis=1)
    return np.linalg.norm(cp - cq, axis=2), cp, cq
