# cython: language_level=3
"""The triangle pairs of first contacts between two placed bodies: for each contact, every pair of
triangles whose boxes come within ``reach`` of each other (and, asked, neither of which lies wholly
beyond the other's plane by more than ``reach``), after shrinking each side to the box of
the other's near triangles (``collision.vehicles.contact_centres``; its numpy twin is
``collision.contact_pairs.near_triangle_pairs_numpy``, which the tests compare pair for pair)."""

import numpy as np

cimport numpy as cnp
from libc.math cimport INFINITY, sqrt

cnp.import_array()


cdef inline bint _in_box(const double[:, :] lo, const double[:, :] hi, Py_ssize_t j,
                         double *blo, double *bhi, double reach) noexcept nogil:
    """Triangle j's box lies within ``reach`` of the box (blo, bhi) on every axis, as numpy's
    ``(lo <= bhi + reach) & (hi >= blo - reach)`` says it (the same two roundings)."""
    cdef int c
    for c in range(3):
        if not (lo[j, c] <= bhi[c] + reach and hi[j, c] >= blo[c] - reach):
            return False
    return True


cdef inline void _box_of(const double[:, :] lo, const double[:, :] hi, Py_ssize_t[:] idx, Py_ssize_t n,
                         double *blo, double *bhi) noexcept nogil:
    """The box of the triangles idx[:n] (inf, -inf where there are none)."""
    cdef int c
    cdef Py_ssize_t k, j
    for c in range(3):
        blo[c] = INFINITY
        bhi[c] = -INFINITY
    for k in range(n):
        j = idx[k]
        for c in range(3):
            if lo[j, c] < blo[c]:
                blo[c] = lo[j, c]
            if hi[j, c] > bhi[c]:
                bhi[c] = hi[j, c]


cdef void _boxes(const double[:, :, :] T, double[:, :] lo, double[:, :] hi) noexcept nogil:
    """Each triangle's box (T (m, 3, 3) in, lo and hi (m, 3) out), as numpy's min and max over its
    vertices give it."""
    cdef Py_ssize_t j
    cdef int c, v
    for j in range(T.shape[0]):
        for c in range(3):
            lo[j, c] = T[j, 0, c]
            hi[j, c] = T[j, 0, c]
            for v in range(1, 3):
                if T[j, v, c] < lo[j, c]:
                    lo[j, c] = T[j, v, c]
                if T[j, v, c] > hi[j, c]:
                    hi[j, c] = T[j, v, c]


cdef void _normals(const double[:, :, :] T, double[:, :] n, unsigned char[:] ok) noexcept nogil:
    """Each triangle's unit normal (T (m, 3, 3) in; n (m, 3) and ok (m,), a nonzero area, out), as
    numpy's cross product and norm give it (the same roundings)."""
    cdef Py_ssize_t j
    cdef double ux, uy, uz, vx, vy, vz, x, y, z, size
    for j in range(T.shape[0]):
        ux = T[j, 1, 0] - T[j, 0, 0]
        uy = T[j, 1, 1] - T[j, 0, 1]
        uz = T[j, 1, 2] - T[j, 0, 2]
        vx = T[j, 2, 0] - T[j, 0, 0]
        vy = T[j, 2, 1] - T[j, 0, 1]
        vz = T[j, 2, 2] - T[j, 0, 2]
        x = uy * vz - uz * vy
        y = uz * vx - ux * vz
        z = ux * vy - uy * vx
        size = sqrt(x * x + y * y + z * z)
        ok[j] = size > 0
        if ok[j]:
            x, y, z = x / size, y / size, z / size
        n[j, 0] = x
        n[j, 1] = y
        n[j, 2] = z


cdef inline bint _beyond(const double[:, :, :] X, Py_ssize_t i, const double[:, :] n, const unsigned char[:] ok,
                         const double[:, :, :] Y, Py_ssize_t j, double reach) noexcept nogil:
    """Triangle Y[j] lies wholly farther than ``reach`` beyond triangle X[i]'s plane, on one side
    (a lower bound of their distance; never for a triangle of no area)."""
    cdef int v
    cdef double side
    cdef bint above = True, below = True
    if not ok[i]:
        return False
    for v in range(3):
        side = ((Y[j, v, 0] - X[i, 0, 0]) * n[i, 0] + (Y[j, v, 1] - X[i, 0, 1]) * n[i, 1]
                + (Y[j, v, 2] - X[i, 0, 2]) * n[i, 2])
        above = above and side > reach
        below = below and side < -reach
    return above or below


def near_triangle_pairs(const double[:, :, :, :] A, const double[:, :, :, :] B, double reach, int rounds=3,
                        bint planes=False):
    """For K contacts, body a's placed triangles A (K, ma, 3, 3) and body b's B (K, mb, 3, 3), m:
    (owner, ia, ib) int64 each, every pair (ia, ib) of contact ``owner`` whose boxes come within
    ``reach`` (m) on every axis, after ``rounds`` rounds of keeping each side's triangles within
    ``reach`` of the box of the other's kept ones; in contact order, then ia, then ib (np.nonzero's).
    ``planes``: also drop the pairs one of whose triangles lies wholly farther than ``reach`` beyond
    the other's plane (a lower bound of their distance: they are not within ``reach`` either)."""
    cdef Py_ssize_t K = A.shape[0], ma = A.shape[1], mb = B.shape[1]
    cdef Py_ssize_t i, k, j, na, nb, ka, kb, n_out = 0, cap = 1024
    cdef double box_lo[3]
    cdef double box_hi[3]
    cdef int r, c
    cdef bint ok
    near_a_arr = np.empty(ma, dtype=np.intp)
    near_b_arr = np.empty(mb, dtype=np.intp)
    cdef Py_ssize_t[:] near_a = near_a_arr
    cdef Py_ssize_t[:] near_b = near_b_arr
    cdef double[:, :] alo = np.empty((ma, 3)), ahi = np.empty((ma, 3))
    cdef double[:, :] blo = np.empty((mb, 3)), bhi = np.empty((mb, 3))
    cdef double[:, :] an = np.empty((ma, 3)), bn = np.empty((mb, 3))
    cdef unsigned char[:] a_ok = np.empty(ma, np.uint8), b_ok = np.empty(mb, np.uint8)
    out_arr = np.empty((cap, 3), dtype=np.int64)
    cdef cnp.int64_t[:, :] out = out_arr
    for i in range(K):
        _boxes(A[i], alo, ahi)
        _boxes(B[i], blo, bhi)
        for k in range(ma):
            near_a[k] = k
        for k in range(mb):
            near_b[k] = k
        na, nb = ma, mb
        for r in range(rounds):
            _box_of(blo, bhi, near_b, nb, box_lo, box_hi)
            k = 0
            for j in range(na):
                if _in_box(alo, ahi, near_a[j], box_lo, box_hi, reach):
                    near_a[k] = near_a[j]
                    k += 1
            na = k
            _box_of(alo, ahi, near_a, na, box_lo, box_hi)
            k = 0
            for j in range(nb):
                if _in_box(blo, bhi, near_b[j], box_lo, box_hi, reach):
                    near_b[k] = near_b[j]
                    k += 1
            nb = k
        if planes:
            _normals(A[i], an, a_ok)
            _normals(B[i], bn, b_ok)
        for ka in range(na):
            for kb in range(nb):
                ok = True
                for c in range(3):
                    if not (alo[near_a[ka], c] <= bhi[near_b[kb], c] + reach
                            and ahi[near_a[ka], c] >= blo[near_b[kb], c] - reach):
                        ok = False
                        break
                if not ok:
                    continue
                if planes and (_beyond(A[i], near_a[ka], an, a_ok, B[i], near_b[kb], reach)
                               or _beyond(B[i], near_b[kb], bn, b_ok, A[i], near_a[ka], reach)):
                    continue
                if n_out == cap:
                    cap *= 2
                    grown = np.empty((cap, 3), dtype=np.int64)
                    grown[:n_out] = out_arr[:n_out]
                    out_arr = grown
                    out = out_arr
                out[n_out, 0] = i
                out[n_out, 1] = near_a[ka]
                out[n_out, 2] = near_b[kb]
                n_out += 1
    pairs = out_arr[:n_out]
    return pairs[:, 0].copy(), pairs[:, 1].copy(), pairs[:, 2].copy()


cdef inline double _dot(const double* x, const double* y) noexcept nogil:
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


cdef inline double _clip01(double v) noexcept nogil:
    """np.clip(v, 0, 1): NaN stays NaN."""
    if v < 0:
        return 0.0
    if v > 1:
        return 1.0
    return v


cdef void _closest_on_triangle(const double* p, const double* a, const double* b, const double* c,
                               double* out) noexcept nogil:
    """The closest point of triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5), the
    regions tested in the numpy twin's order, the face's formula where none holds."""
    cdef double ab[3]
    cdef double ac[3]
    cdef double ap[3]
    cdef double bp[3]
    cdef double cp[3]
    cdef double cb[3]
    cdef int i
    for i in range(3):
        ab[i] = b[i] - a[i]
        ac[i] = c[i] - a[i]
        ap[i] = p[i] - a[i]
        bp[i] = p[i] - b[i]
        cp[i] = p[i] - c[i]
        cb[i] = c[i] - b[i]
    cdef double d1 = _dot(ab, ap), d2 = _dot(ac, ap)
    cdef double d3 = _dot(ab, bp), d4 = _dot(ac, bp)
    cdef double d5 = _dot(ab, cp), d6 = _dot(ac, cp)
    cdef double va = d3 * d6 - d5 * d4, vb = d5 * d2 - d1 * d6, vc = d1 * d4 - d3 * d2
    cdef double t, denom, v, w
    if d1 <= 0 and d2 <= 0:
        for i in range(3):
            out[i] = a[i]
    elif d3 >= 0 and d4 <= d3:
        for i in range(3):
            out[i] = b[i]
    elif d6 >= 0 and d5 <= d6:
        for i in range(3):
            out[i] = c[i]
    elif vc <= 0 and d1 >= 0 and d3 <= 0:
        t = d1 / (d1 - d3)
        for i in range(3):
            out[i] = a[i] + ab[i] * t
    elif vb <= 0 and d2 >= 0 and d6 <= 0:
        t = d2 / (d2 - d6)
        for i in range(3):
            out[i] = a[i] + ac[i] * t
    elif va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        for i in range(3):
            out[i] = b[i] + cb[i] * t
    else:
        denom = 1.0 / (va + vb + vc)
        v = vb * denom
        w = vc * denom
        for i in range(3):
            out[i] = a[i] + ab[i] * v + ac[i] * w


cdef void _closest_on_segments(const double* p1, const double* q1, const double* p2, const double* q2,
                               double* o1, double* o2) noexcept nogil:
    """The closest points of segments p1q1 and p2q2 (Ericson 5.1.9), as the numpy twin's selections
    give them (a zero-length segment is its point)."""
    cdef double d1[3]
    cdef double d2[3]
    cdef double r[3]
    cdef int i
    for i in range(3):
        d1[i] = q1[i] - p1[i]
        d2[i] = q2[i] - p2[i]
        r[i] = p1[i] - p2[i]
    cdef double a = _dot(d1, d1), e = _dot(d2, d2), f = _dot(d2, r), c = _dot(d1, r), b = _dot(d1, d2)
    cdef double tiny = 1e-300
    cdef double den = a * e - b * b
    cdef double s, t
    s = _clip01((b * f - c * e) / den) if den > tiny else 0.0
    if not a > tiny:
        s = 0.0
    t = (b * s + f) / e if e > tiny else 0.0
    if t < 0:
        s = _clip01(-c / a) if a > tiny else 0.0
    elif t > 1:
        s = _clip01((b - c) / a) if a > tiny else 0.0
    t = _clip01(t)
    for i in range(3):
        o1[i] = p1[i] + d1[i] * s
        o2[i] = p2[i] + d2[i] * t


def triangle_pair_features(const double[:, :, ::1] P, const double[:, :, ::1] Q):
    """The 15 feature pairs of triangle pairs P[j], Q[j] (J, 3, 3), m: each one's vertices against the
    other triangle (6: P's vertex k, then Q's vertex k, for k = 0, 1, 2) and the nine edge pairs
    (P's edge i against Q's edge j, edge i from vertex i to i + 1), as distances (J, 15) and their
    closest points on P (J, 15, 3) and on Q (J, 15, 3). The least of a pair's 15 is its distance where
    the triangles do not cross (where they do, at most the crossing's depth). The numpy twin is
    ``collision.contact_pairs.triangle_pair_features_numpy``."""
    cdef Py_ssize_t J = P.shape[0], j
    if Q.shape[0] != J:
        raise ValueError("triangle_pair_features: P and Q need as many triangles")
    d_arr = np.empty((J, 15))
    cp_arr = np.empty((J, 15, 3))
    cq_arr = np.empty((J, 15, 3))
    cdef double[:, ::1] d = d_arr
    cdef double[:, :, ::1] cp = cp_arr
    cdef double[:, :, ::1] cq = cq_arr
    cdef int k, i, n, c
    cdef double dx, dy, dz
    with nogil:
        for j in range(J):
            for k in range(3):
                for c in range(3):
                    cp[j, 2 * k, c] = P[j, k, c]
                    cq[j, 2 * k + 1, c] = Q[j, k, c]
                _closest_on_triangle(&P[j, k, 0], &Q[j, 0, 0], &Q[j, 1, 0], &Q[j, 2, 0], &cq[j, 2 * k, 0])
                _closest_on_triangle(&Q[j, k, 0], &P[j, 0, 0], &P[j, 1, 0], &P[j, 2, 0], &cp[j, 2 * k + 1, 0])
            n = 6
            for i in range(3):
                for k in range(3):
                    _closest_on_segments(&P[j, i, 0], &P[j, (i + 1) % 3, 0], &Q[j, k, 0], &Q[j, (k + 1) % 3, 0],
                                         &cp[j, n, 0], &cq[j, n, 0])
                    n += 1
            for n in range(15):
                dx = cp[j, n, 0] - cq[j, n, 0]
                dy = cp[j, n, 1] - cq[j, n, 1]
                dz = cp[j, n, 2] - cq[j, n, 2]
                d[j, n] = sqrt(dx * dx + dy * dy + dz * dz)
    return d_arr, cp_arr, cq_arr
