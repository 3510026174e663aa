"""Exact triangle-triangle intersection (closed triangles: touching counts), compiled ahead of time (Cython).

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
coplanar ones). The test is ``tri_tri_c`` in ``_triangles.pxd`` (nogil, for
the compiled tree traversal to cimport); ``tri_tri`` is its Python face.

``tri_tri_brute`` is an independent oracle for the tests: two triangles meet
iff an edge of one meets the other (Moller-Trumbore, closed), or, when
coplanar, an edge crosses an edge or a vertex lies inside.

``tri_distance`` is the distance between two closed triangles (0 when they meet): the least
of the nine edge-edge distances and the six vertex-face projections, which is where two
disjoint triangles are closest (``tri_tri_distance_c``, for the compiled sweeps).
``tri_distance_brute`` is its oracle: the convex problem over both triangles' barycentric
coordinates solved numerically.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.geometry._triangles import REL_EPS, tri_distance, tri_tri  # noqa: F401


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


def tri_distance_brute(P: np.ndarray, Q: np.ndarray) -> float:
    """Independent oracle (one pair): min |P(a) - Q(b)| over barycentric a, b, by SLSQP from several
    starts (scipy), then the best of those and of the nine vertex pairs."""
    from scipy.optimize import minimize

    P = np.asarray(P, dtype=float)
    Q = np.asarray(Q, dtype=float)
    origin = P[0]
    P, Q = P - origin, Q - origin  # differences keep the oracle as precise as the test itself

    def point(T, w):
        return T[0] + w[0] * (T[1] - T[0]) + w[1] * (T[2] - T[0])

    def f(z):
        d = point(P, z[:2]) - point(Q, z[2:])
        return d @ d

    cons = [{"type": "ineq", "fun": lambda z, i=i: z[i]} for i in range(4)]
    cons += [{"type": "ineq", "fun": lambda z: 1 - z[0] - z[1]}, {"type": "ineq", "fun": lambda z: 1 - z[2] - z[3]}]
    best = min(float(np.sum((p - q) ** 2)) for p in P for q in Q)
    for start in ([1 / 3] * 4, [0.1, 0.1, 0.8, 0.1], [0.8, 0.1, 0.1, 0.1], [0.1, 0.8, 0.1, 0.8], [0.5, 0.5, 0.5, 0.0]):
        res = minimize(f, np.array(start), constraints=cons, method="SLSQP", options={"ftol": 1e-16, "maxiter": 500})
        z = np.clip(res.x, 0, 1)
        for w in (z[:2], z[2:]):
            excess = w.sum() - 1
            if excess > 0:
                w -= excess / 2
        best = min(best, f(z))
    return float(np.sqrt(max(best, 0.0)))
