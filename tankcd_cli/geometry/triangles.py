"""Exact triangle-triangle intersection (closed triangles: touching counts).

``tri_tri`` follows Moller's interval test ("A fast triangle-triangle
intersection test", JGT 1997): each triangle's vertices are classified
against the other's plane; if both triangles straddle (or touch) the other's
plane, their intersections with the line common to both planes are intervals,
and the triangles meet iff the intervals overlap. Coplanar triangles are
projected to the plane's dominant axes and tested for edge crossings and
containment. Signed distances below a tolerance relative to the triangles'
size count as zero (Moller's epsilon), so touching and coplanar contact is
detected rather than lost to round-off. It returns a contact point on both
triangles (the middle of the overlap of the intervals, or a shared point of
coplanar ones).

``tri_tri_brute`` is an independent oracle for the tests: two triangles meet
iff an edge of one meets the other (Moller-Trumbore, closed), or, when
coplanar, an edge crosses an edge or a vertex lies inside.
"""

from __future__ import annotations

import numpy as np
from numba import njit

REL_EPS = 1e-12


@njit(cache=True, inline="always")
def _sub(a, b):  # pragma: no cover - compiled
    return a[0] - b[0], a[1] - b[1], a[2] - b[2]


@njit(cache=True, inline="always")
def _cross(ax, ay, az, bx, by, bz):  # pragma: no cover - compiled
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit(cache=True)
def _seg_seg_2d(ax, ay, bx, by, cx, cy, dx, dy, eps):  # pragma: no cover - compiled
    """Closed segments ab and cd in the plane intersect."""
    d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    d3 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    d4 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    if ((d1 > eps and d2 < -eps) or (d1 < -eps and d2 > eps)) and ((d3 > eps and d4 < -eps) or (d3 < -eps and d4 > eps)):
        return True
    # collinear or touching: bounding-box overlap on the line
    if abs(d1) <= eps and min(cx, dx) - eps <= ax <= max(cx, dx) + eps and min(cy, dy) - eps <= ay <= max(cy, dy) + eps:
        return True
    if abs(d2) <= eps and min(cx, dx) - eps <= bx <= max(cx, dx) + eps and min(cy, dy) - eps <= by <= max(cy, dy) + eps:
        return True
    if abs(d3) <= eps and min(ax, bx) - eps <= cx <= max(ax, bx) + eps and min(ay, by) - eps <= cy <= max(ay, by) + eps:
        return True
    if abs(d4) <= eps and min(ax, bx) - eps <= dx <= max(ax, bx) + eps and min(ay, by) - eps <= dy <= max(ay, by) + eps:
        return True
    return False


@njit(cache=True)
def _inside_2d(px, py, ax, ay, bx, by, cx, cy, eps):  # pragma: no cover - compiled
    s0 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    s1 = (cx - bx) * (py - by) - (cy - by) * (px - bx)
    s2 = (ax - cx) * (py - cy) - (ay - cy) * (px - cx)
    return (s0 >= -eps and s1 >= -eps and s2 >= -eps) or (s0 <= eps and s1 <= eps and s2 <= eps)


@njit(cache=True)
def _coplanar(P, Q, nx, ny, nz, scale, out):  # pragma: no cover - compiled
    ax = abs(nx)
    ay = abs(ny)
    az = abs(nz)
    if ax >= ay and ax >= az:
        i0, i1 = 1, 2
    elif ay >= az:
        i0, i1 = 0, 2
    else:
        i0, i1 = 0, 1
    eps = REL_EPS * scale * scale
    for a in range(3):
        b = (a + 1) % 3
        for c in range(3):
            d = (c + 1) % 3
            if _seg_seg_2d(P[a, i0], P[a, i1], P[b, i0], P[b, i1], Q[c, i0], Q[c, i1], Q[d, i0], Q[d, i1], eps):
                _edge_crossing_point(P[a], P[b], Q[c], Q[d], i0, i1, out)
                return True
    for a in range(3):
        if _inside_2d(P[a, i0], P[a, i1], Q[0, i0], Q[0, i1], Q[1, i0], Q[1, i1], Q[2, i0], Q[2, i1], eps):
            for m in range(3):
                out[m] = P[a, m]
            return True
        if _inside_2d(Q[a, i0], Q[a, i1], P[0, i0], P[0, i1], P[1, i0], P[1, i1], P[2, i0], P[2, i1], eps):
            for m in range(3):
                out[m] = Q[a, m]
            return True
    return False


@njit(cache=True)
def _edge_crossing_point(a, b, c, d, i0, i1, out):  # pragma: no cover - compiled
    ex = b[i0] - a[i0]
    ey = b[i1] - a[i1]
    fx = d[i0] - c[i0]
    fy = d[i1] - c[i1]
    den = ex * fy - ey * fx
    t = 0.0
    if den != 0.0:
        t = ((c[i0] - a[i0]) * fy - (c[i1] - a[i1]) * fx) / den
        t = min(max(t, 0.0), 1.0)
    for m in range(3):
        out[m] = a[m] + t * (b[m] - a[m])


@njit(cache=True)
def _plane_crossing(T, d, out_a, out_b):  # pragma: no cover - compiled
    """Endpoints of the segment where triangle T meets the plane whose signed distances are d."""
    k = 0
    for a in range(3):
        b = (a + 1) % 3
        if d[a] == 0.0:
            if k == 0:
                for m in range(3):
                    out_a[m] = T[a, m]
            else:
                for m in range(3):
                    out_b[m] = T[a, m]
            k += 1
        if (d[a] > 0.0 and d[b] < 0.0) or (d[a] < 0.0 and d[b] > 0.0):
            t = d[a] / (d[a] - d[b])
            if k == 0:
                for m in range(3):
                    out_a[m] = T[a, m] + t * (T[b, m] - T[a, m])
            else:
                for m in range(3):
                    out_b[m] = T[a, m] + t * (T[b, m] - T[a, m])
            k += 1
        if k >= 2:
            break
    if k == 1:
        for m in range(3):
            out_b[m] = out_a[m]


@njit(cache=True)
def tri_tri(P, Q, out, scratch=None):  # pragma: no cover - compiled
    """Whether closed triangles P and Q (3, 3) meet; if so, ``out`` (3,) receives a common point.

    ``scratch`` (6, 3), if given, saves the small allocations in hot loops.
    """
    e1 = _sub(Q[1], Q[0])
    e2 = _sub(Q[2], Q[0])
    nqx, nqy, nqz = _cross(e1[0], e1[1], e1[2], e2[0], e2[1], e2[2])
    f1 = _sub(P[1], P[0])
    f2 = _sub(P[2], P[0])
    npx, npy, npz = _cross(f1[0], f1[1], f1[2], f2[0], f2[1], f2[2])
    scale = 0.0
    for a in range(3):
        for m in range(3):
            scale = max(scale, abs(P[a, m] - Q[0, m]))
    scale = max(scale, 1e-300)
    nq = np.sqrt(nqx * nqx + nqy * nqy + nqz * nqz)
    npn = np.sqrt(npx * npx + npy * npy + npz * npz)
    if nq == 0.0 or npn == 0.0:
        return False  # a degenerate triangle has no interior: callers drop them
    dp = np.empty(3) if scratch is None else scratch[4]
    dq = np.empty(3) if scratch is None else scratch[5]
    for a in range(3):
        dp[a] = (nqx * (P[a, 0] - Q[0, 0]) + nqy * (P[a, 1] - Q[0, 1]) + nqz * (P[a, 2] - Q[0, 2])) / nq
        if abs(dp[a]) <= REL_EPS * scale:
            dp[a] = 0.0
    if (dp[0] > 0 and dp[1] > 0 and dp[2] > 0) or (dp[0] < 0 and dp[1] < 0 and dp[2] < 0):
        return False
    for a in range(3):
        dq[a] = (npx * (Q[a, 0] - P[0, 0]) + npy * (Q[a, 1] - P[0, 1]) + npz * (Q[a, 2] - P[0, 2])) / npn
        if abs(dq[a]) <= REL_EPS * scale:
            dq[a] = 0.0
    if (dq[0] > 0 and dq[1] > 0 and dq[2] > 0) or (dq[0] < 0 and dq[1] < 0 and dq[2] < 0):
        return False
    if dp[0] == 0.0 and dp[1] == 0.0 and dp[2] == 0.0:
        return _coplanar(P, Q, nqx, nqy, nqz, scale, out)
    # both straddle: the segments where each meets the other's plane lie on one line
    if scratch is None:
        scratch = np.empty((6, 3))
    pa = scratch[0]
    pb = scratch[1]
    qa = scratch[2]
    qb = scratch[3]
    _plane_crossing(P, dp, pa, pb)
    _plane_crossing(Q, dq, qa, qb)
    lx, ly, lz = _cross(npx, npy, npz, nqx, nqy, nqz)
    tpa = lx * pa[0] + ly * pa[1] + lz * pa[2]
    tpb = lx * pb[0] + ly * pb[1] + lz * pb[2]
    tqa = lx * qa[0] + ly * qa[1] + lz * qa[2]
    tqb = lx * qb[0] + ly * qb[1] + lz * qb[2]
    if tpa > tpb:
        tpa, tpb = tpb, tpa
        for m in range(3):
            pa[m], pb[m] = pb[m], pa[m]
    if tqa > tqb:
        tqa, tqb = tqb, tqa
        for m in range(3):
            qa[m], qb[m] = qb[m], qa[m]
    tol = REL_EPS * scale * np.sqrt(lx * lx + ly * ly + lz * lz) * scale
    lo = max(tpa, tqa)
    hi = min(tpb, tqb)
    if lo > hi + tol:
        return False
    # the middle of the overlap, on P's segment
    mid = 0.5 * (lo + hi)
    span = tpb - tpa
    t = 0.5 if span <= 0.0 else min(max((mid - tpa) / span, 0.0), 1.0)
    for m in range(3):
        out[m] = pa[m] + t * (pb[m] - pa[m])
    return True


def tri_tri_brute(P: np.ndarray, Q: np.ndarray) -> bool:
    """Independent oracle (numpy, one pair): edges against triangles, 2D tests when coplanar."""
    P = np.asarray(P, dtype=float)
    Q = np.asarray(Q, dtype=float)
    scale = max(np.abs(P - Q[0]).max(), np.abs(Q - Q[0]).max(), 1e-300)
    nq = np.cross(Q[1] - Q[0], Q[2] - Q[0])
    dist = (P - Q[0]) @ nq / np.linalg.norm(nq)
    if np.all(np.abs(dist) <= 1e-10 * scale):
        axes = [i for i in range(3) if i != int(np.argmax(np.abs(nq)))]
        p2, q2 = P[:, axes], Q[:, axes]
        return _coplanar_brute(p2, q2, 1e-10 * scale * scale)

    def seg_tri(a, b, T):
        d = b - a
        e1, e2 = T[1] - T[0], T[2] - T[0]
        h = np.cross(d, e2)
        det = e1 @ h
        n = np.cross(e1, e2)
        if abs(det) <= 1e-14 * np.linalg.norm(d) * np.linalg.norm(n):
            return False  # parallel to the plane: the other tests cover any contact
        s = a - T[0]
        u = (s @ h) / det
        q = np.cross(s, e1)
        v = (d @ q) / det
        t = (e2 @ q) / det
        tol = 1e-9
        return u >= -tol and v >= -tol and u + v <= 1 + tol and -tol <= t <= 1 + tol

    for T, S in ((P, Q), (Q, P)):
        for i in range(3):
            if seg_tri(T[i], T[(i + 1) % 3], S):
                return True
    return False


def _coplanar_brute(p, q, eps):
    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    def inside(pt, T):
        s = [orient(T[i], T[(i + 1) % 3], pt) for i in range(3)]
        return all(x >= -eps for x in s) or all(x <= eps for x in s)

    def on_segment(a, b, c):
        return min(a[0], b[0]) - 1e-12 <= c[0] <= max(a[0], b[0]) + 1e-12 and min(a[1], b[1]) - 1e-12 <= c[1] <= max(a[1], b[1]) + 1e-12

    for i in range(3):
        a, b = p[i], p[(i + 1) % 3]
        for j in range(3):
            c, d = q[j], q[(j + 1) % 3]
            d1, d2, d3, d4 = orient(c, d, a), orient(c, d, b), orient(a, b, c), orient(a, b, d)
            if d1 * d2 < 0 and d3 * d4 < 0:
                return True
            if (abs(d1) <= eps and on_segment(c, d, a)) or (abs(d2) <= eps and on_segment(c, d, b)) or \
               (abs(d3) <= eps and on_segment(a, b, c)) or (abs(d4) <= eps and on_segment(a, b, d)):
                return True
    return any(inside(v, q) for v in p) or any(inside(v, p) for v in q)
