# Moller's triangle-triangle test as nogil C-level helpers (see triangles.py for the method).
#
# Defined here, inline, so that every module that cimports ``tri_tri_c`` (the tree traversal)
# compiles it in and calls it directly; its arithmetic has one fixed order (no fused multiply-add:
# setup.py builds with -ffp-contract=off), so every caller gets the same bits. Triangles are 9
# contiguous doubles, vertex-major
# ((3, 3) C order); points are 3 doubles.

from libc.math cimport fabs, sqrt, INFINITY


cdef inline double _rel_eps() noexcept nogil:
    return 1e-12  # REL_EPS of triangles.py


cdef inline double pymax(double a, double b) noexcept nogil:
    """Python's max(a, b): b only when b > a (a NaN never replaces an earlier value)."""
    return b if b > a else a


cdef inline double pymin(double a, double b) noexcept nogil:
    """Python's min(a, b): b only when b < a."""
    return b if b < a else a


cdef inline bint _seg_seg_2d(double ax, double ay, double bx, double by, double cx, double cy, double dx,
                             double dy, double eps) noexcept nogil:
    """Closed segments ab and cd in the plane intersect."""
    cdef double d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    cdef double d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    cdef double d3 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    cdef double d4 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    if (((d1 > eps and d2 < -eps) or (d1 < -eps and d2 > eps))
            and ((d3 > eps and d4 < -eps) or (d3 < -eps and d4 > eps))):
        return True
    # collinear or touching: bounding-box overlap on the line
    if (fabs(d1) <= eps and pymin(cx, dx) - eps <= ax <= pymax(cx, dx) + eps
            and pymin(cy, dy) - eps <= ay <= pymax(cy, dy) + eps):
        return True
    if (fabs(d2) <= eps and pymin(cx, dx) - eps <= bx <= pymax(cx, dx) + eps
            and pymin(cy, dy) - eps <= by <= pymax(cy, dy) + eps):
        return True
    if (fabs(d3) <= eps and pymin(ax, bx) - eps <= cx <= pymax(ax, bx) + eps
            and pymin(ay, by) - eps <= cy <= pymax(ay, by) + eps):
        return True
    if (fabs(d4) <= eps and pymin(ax, bx) - eps <= dx <= pymax(ax, bx) + eps
            and pymin(ay, by) - eps <= dy <= pymax(ay, by) + eps):
        return True
    return False


cdef inline bint _inside_2d(double px, double py, double ax, double ay, double bx, double by, double cx,
                            double cy, double eps) noexcept nogil:
    cdef double s0 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    cdef double s1 = (cx - bx) * (py - by) - (cy - by) * (px - bx)
    cdef double s2 = (ax - cx) * (py - cy) - (ay - cy) * (px - cx)
    return (s0 >= -eps and s1 >= -eps and s2 >= -eps) or (s0 <= eps and s1 <= eps and s2 <= eps)


cdef inline void _edge_crossing_point(const double* a, const double* b, const double* c, const double* d,
                                      int i0, int i1, double* out) noexcept nogil:
    cdef double ex = b[i0] - a[i0]
    cdef double ey = b[i1] - a[i1]
    cdef double fx = d[i0] - c[i0]
    cdef double fy = d[i1] - c[i1]
    cdef double den = ex * fy - ey * fx
    cdef double t = 0.0
    cdef int m
    if den != 0.0:
        t = ((c[i0] - a[i0]) * fy - (c[i1] - a[i1]) * fx) / den
        t = pymin(pymax(t, 0.0), 1.0)
    for m in range(3):
        out[m] = a[m] + t * (b[m] - a[m])


cdef inline bint _coplanar(const double* P, const double* Q, double nx, double ny, double nz, double scale,
                           double* out) noexcept nogil:
    cdef double ax = fabs(nx)
    cdef double ay = fabs(ny)
    cdef double az = fabs(nz)
    cdef int i0, i1, a, b, c, d, m
    if ax >= ay and ax >= az:
        i0 = 1
        i1 = 2
    elif ay >= az:
        i0 = 0
        i1 = 2
    else:
        i0 = 0
        i1 = 1
    cdef double eps = _rel_eps() * scale * scale
    for a in range(3):
        b = (a + 1) % 3
        for c in range(3):
            d = (c + 1) % 3
            if _seg_seg_2d(P[3 * a + i0], P[3 * a + i1], P[3 * b + i0], P[3 * b + i1],
                           Q[3 * c + i0], Q[3 * c + i1], Q[3 * d + i0], Q[3 * d + i1], eps):
                _edge_crossing_point(P + 3 * a, P + 3 * b, Q + 3 * c, Q + 3 * d, i0, i1, out)
                return True
    for a in range(3):
        if _inside_2d(P[3 * a + i0], P[3 * a + i1], Q[i0], Q[i1], Q[3 + i0], Q[3 + i1], Q[6 + i0], Q[6 + i1],
                      eps):
            for m in range(3):
                out[m] = P[3 * a + m]
            return True
        if _inside_2d(Q[3 * a + i0], Q[3 * a + i1], P[i0], P[i1], P[3 + i0], P[3 + i1], P[6 + i0], P[6 + i1],
                      eps):
            for m in range(3):
                out[m] = Q[3 * a + m]
            return True
    return False


cdef inline void _plane_crossing(const double* T, const double* d, double* out_a, double* out_b) noexcept nogil:
    """Endpoints of the segment where triangle T meets the plane whose signed distances are d."""
    cdef int k = 0
    cdef int a, b, m
    cdef double t
    for a in range(3):
        b = (a + 1) % 3
        if d[a] == 0.0:
            if k == 0:
                for m in range(3):
                    out_a[m] = T[3 * a + m]
            else:
                for m in range(3):
                    out_b[m] = T[3 * a + m]
            k += 1
        if (d[a] > 0.0 and d[b] < 0.0) or (d[a] < 0.0 and d[b] > 0.0):
            t = d[a] / (d[a] - d[b])
            if k == 0:
                for m in range(3):
                    out_a[m] = T[3 * a + m] + t * (T[3 * b + m] - T[3 * a + m])
            else:
                for m in range(3):
                    out_b[m] = T[3 * a + m] + t * (T[3 * b + m] - T[3 * a + m])
            k += 1
        if k >= 2:
            break
    if k == 1:
        for m in range(3):
            out_b[m] = out_a[m]


cdef inline bint tri_tri_c(const double* P, const double* Q, double* out, double* scratch) noexcept nogil:
    """Whether closed triangles P and Q meet; if so, ``out`` receives a common point.

    ``scratch`` is 18 doubles of working space (the (6, 3) scratch of the Python-level test).
    """
    cdef double e1x = Q[3] - Q[0]
    cdef double e1y = Q[4] - Q[1]
    cdef double e1z = Q[5] - Q[2]
    cdef double e2x = Q[6] - Q[0]
    cdef double e2y = Q[7] - Q[1]
    cdef double e2z = Q[8] - Q[2]
    cdef double nqx = e1y * e2z - e1z * e2y
    cdef double nqy = e1z * e2x - e1x * e2z
    cdef double nqz = e1x * e2y - e1y * e2x
    cdef double f1x = P[3] - P[0]
    cdef double f1y = P[4] - P[1]
    cdef double f1z = P[5] - P[2]
    cdef double f2x = P[6] - P[0]
    cdef double f2y = P[7] - P[1]
    cdef double f2z = P[8] - P[2]
    cdef double npx = f1y * f2z - f1z * f2y
    cdef double npy = f1z * f2x - f1x * f2z
    cdef double npz = f1x * f2y - f1y * f2x
    cdef double scale = 0.0
    cdef int a, m
    for a in range(3):
        for m in range(3):
            scale = pymax(scale, fabs(P[3 * a + m] - Q[m]))
    scale = pymax(scale, 1e-300)
    cdef double nq = sqrt(nqx * nqx + nqy * nqy + nqz * nqz)
    cdef double npn = sqrt(npx * npx + npy * npy + npz * npz)
    if nq == 0.0 or npn == 0.0:
        return False  # a degenerate triangle has no interior: callers drop them
    cdef double* dp = scratch + 12
    cdef double* dq = scratch + 15
    for a in range(3):
        dp[a] = (nqx * (P[3 * a] - Q[0]) + nqy * (P[3 * a + 1] - Q[1]) + nqz * (P[3 * a + 2] - Q[2])) / nq
        if fabs(dp[a]) <= _rel_eps() * scale:
            dp[a] = 0.0
    if (dp[0] > 0 and dp[1] > 0 and dp[2] > 0) or (dp[0] < 0 and dp[1] < 0 and dp[2] < 0):
        return False
    for a in range(3):
        dq[a] = (npx * (Q[3 * a] - P[0]) + npy * (Q[3 * a + 1] - P[1]) + npz * (Q[3 * a + 2] - P[2])) / npn
        if fabs(dq[a]) <= _rel_eps() * scale:
            dq[a] = 0.0
    if (dq[0] > 0 and dq[1] > 0 and dq[2] > 0) or (dq[0] < 0 and dq[1] < 0 and dq[2] < 0):
        return False
    if dp[0] == 0.0 and dp[1] == 0.0 and dp[2] == 0.0:
        return _coplanar(P, Q, nqx, nqy, nqz, scale, out)
    # both straddle: the segments where each meets the other's plane lie on one line
    cdef double* pa = scratch
    cdef double* pb = scratch + 3
    cdef double* qa = scratch + 6
    cdef double* qb = scratch + 9
    _plane_crossing(P, dp, pa, pb)
    _plane_crossing(Q, dq, qa, qb)
    cdef double lx = npy * nqz - npz * nqy
    cdef double ly = npz * nqx - npx * nqz
    cdef double lz = npx * nqy - npy * nqx
    cdef double tpa = lx * pa[0] + ly * pa[1] + lz * pa[2]
    cdef double tpb = lx * pb[0] + ly * pb[1] + lz * pb[2]
    cdef double tqa = lx * qa[0] + ly * qa[1] + lz * qa[2]
    cdef double tqb = lx * qb[0] + ly * qb[1] + lz * qb[2]
    cdef double tmp
    if tpa > tpb:
        tpa, tpb = tpb, tpa
        for m in range(3):
            tmp = pa[m]
            pa[m] = pb[m]
            pb[m] = tmp
    if tqa > tqb:
        tqa, tqb = tqb, tqa
        for m in range(3):
            tmp = qa[m]
            qa[m] = qb[m]
            qb[m] = tmp
    cdef double tol = _rel_eps() * scale * sqrt(lx * lx + ly * ly + lz * lz) * scale
    cdef double lo = pymax(tpa, tqa)
    cdef double hi = pymin(tpb, tqb)
    if lo > hi + tol:
        return False
    # the middle of the overlap, on P's segment
    cdef double mid = 0.5 * (lo + hi)
    cdef double span = tpb - tpa
    cdef double t = 0.5 if span <= 0.0 else pymin(pymax((mid - tpa) / span, 0.0), 1.0)
    for m in range(3):
        out[m] = pa[m] + t * (pb[m] - pa[m])
    return True


# --- distances ---------------------------------------------------------------------------------

cdef inline double _dot3(const double* a, const double* b) noexcept nogil:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


cdef inline double _clamp01(double v) noexcept nogil:
    return 0.0 if v < 0.0 else (1.0 if v > 1.0 else v)


cdef inline double seg_seg_dist2(const double* p1, const double* q1, const double* p2, const double* q2,
                                 double* c1, double* c2) noexcept nogil:
    """Squared distance between closed segments p1q1 and p2q2; c1, c2 receive the closest points
    (Ericson, Real-Time Collision Detection, 5.1.9: degenerate and parallel segments included)."""
    cdef double d1[3]
    cdef double d2[3]
    cdef double r[3]
    cdef int m
    for m in range(3):
        d1[m] = q1[m] - p1[m]
        d2[m] = q2[m] - p2[m]
        r[m] = p1[m] - p2[m]
    cdef double a = _dot3(d1, d1)
    cdef double e = _dot3(d2, d2)
    cdef double f = _dot3(d2, r)
    cdef double s, t, b, c, denom
    if a <= 1e-300 and e <= 1e-300:
        s = 0.0
        t = 0.0
    elif a <= 1e-300:
        s = 0.0
        t = _clamp01(f / e)
    else:
        c = _dot3(d1, r)
        if e <= 1e-300:
            t = 0.0
            s = _clamp01(-c / a)
        else:
            b = _dot3(d1, d2)
            denom = a * e - b * b
            s = _clamp01((b * f - c * e) / denom) if denom > 0.0 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = _clamp01(-c / a)
            elif t > 1.0:
                t = 1.0
                s = _clamp01((b - c) / a)
    cdef double d = 0.0
    cdef double w
    for m in range(3):
        c1[m] = p1[m] + d1[m] * s
        c2[m] = p2[m] + d2[m] * t
        w = c1[m] - c2[m]
        d += w * w
    return d


cdef inline double point_face_dist2(const double* p, const double* T, double* c) noexcept nogil:
    """Squared distance from p to triangle T's plane where p's projection falls inside T (c the
    projection), else +inf: the face case of the point-triangle distance (the edges are the
    segment distances' business)."""
    cdef double ab[3]
    cdef double ac[3]
    cdef double n[3]
    cdef double ap[3]
    cdef int m
    for m in range(3):
        ab[m] = T[3 + m] - T[m]
        ac[m] = T[6 + m] - T[m]
        ap[m] = p[m] - T[m]
    n[0] = ab[1] * ac[2] - ab[2] * ac[1]
    n[1] = ab[2] * ac[0] - ab[0] * ac[2]
    n[2] = ab[0] * ac[1] - ab[1] * ac[0]
    cdef double nn = _dot3(n, n)
    if nn <= 0.0:
        return INFINITY
    cdef double h = _dot3(ap, n) / nn
    cdef double q[3]
    for m in range(3):
        q[m] = p[m] - h * n[m]
    # inside: q on the inner side of all three edges (signs of (edge x (q - start)) . n)
    cdef double e[3]
    cdef double v[3]
    cdef double x[3]
    cdef int k
    for k in range(3):
        for m in range(3):
            e[m] = T[3 * ((k + 1) % 3) + m] - T[3 * k + m]
            v[m] = q[m] - T[3 * k + m]
        x[0] = e[1] * v[2] - e[2] * v[1]
        x[1] = e[2] * v[0] - e[0] * v[2]
        x[2] = e[0] * v[1] - e[1] * v[0]
        if _dot3(x, n) < 0.0:
            return INFINITY
    for m in range(3):
        c[m] = q[m]
    return h * h * nn


cdef inline double tri_tri_distance_c(const double* P, const double* Q, double* cp, double* cq,
                                      double* scratch) noexcept nogil:
    """The distance between closed triangles P and Q (9 doubles each); cp, cq receive a closest pair
    (a common point when they meet: distance 0). A degenerate triangle (no area) has no interior
    and, as in ``tri_tri_c``, meets nothing: +inf.

    Two disjoint triangles are closest at an edge-edge pair or at a vertex and the other's face:
    the minimum over the 9 segment pairs and the 6 vertex-face projections is the distance.
    ``scratch`` is 18 doubles of working space."""
    cdef double e1[3]
    cdef double e2[3]
    cdef int m, i, j
    for m in range(3):
        e1[m] = P[3 + m] - P[m]
        e2[m] = P[6 + m] - P[m]
    if (e1[1] * e2[2] - e1[2] * e2[1]) == 0.0 and (e1[2] * e2[0] - e1[0] * e2[2]) == 0.0 \
            and (e1[0] * e2[1] - e1[1] * e2[0]) == 0.0:
        return INFINITY
    for m in range(3):
        e1[m] = Q[3 + m] - Q[m]
        e2[m] = Q[6 + m] - Q[m]
    if (e1[1] * e2[2] - e1[2] * e2[1]) == 0.0 and (e1[2] * e2[0] - e1[0] * e2[2]) == 0.0 \
            and (e1[0] * e2[1] - e1[1] * e2[0]) == 0.0:
        return INFINITY
    if tri_tri_c(P, Q, cp, scratch):
        for m in range(3):
            cq[m] = cp[m]
        return 0.0
    cdef double best = INFINITY
    cdef double d
    cdef double a[3]
    cdef double b[3]
    for i in range(3):
        for j in range(3):
            d = seg_seg_dist2(P + 3 * i, P + 3 * ((i + 1) % 3), Q + 3 * j, Q + 3 * ((j + 1) % 3), a, b)
            if d < best:
                best = d
                for m in range(3):
                    cp[m] = a[m]
                    cq[m] = b[m]
    for i in range(3):
        d = point_face_dist2(P + 3 * i, Q, b)
        if d < best:
            best = d
            for m in range(3):
                cp[m] = P[3 * i + m]
                cq[m] = b[m]
        d = point_face_dist2(Q + 3 * i, P, a)
        if d < best:
            best = d
            for m in range(3):
                cp[m] = a[m]
                cq[m] = Q[3 * i + m]
    return sqrt(best)
