"""Compiled kernels of ``tankcd_cli.geometry.support_plane`` (see its docstring).

``support_plane_c`` is the walk itself, a C function other kernels cimport (declared in
``_support_plane.pxd``); ``support_plane`` and ``support_planes_fixed`` are its Python faces.
"""

import numpy as np

from cython.parallel cimport prange
from libc.stdint cimport int64_t
from libc.math cimport sqrt, fabs, isfinite, NAN, INFINITY

MAX_PIVOTS = 200

cdef enum:
    _MAX_PIVOTS = 200


cdef inline double _fmin(double a, double b) noexcept nogil:
    """Python's min(a, b): b only when b < a (a NaN never replaces an earlier value)."""
    return b if b < a else a


# The searches below take the point of least ratio num / den (den > 0) within a tie margin of
# 1e-15. A point whose num > lim * den * _RATIO_MARGIN (lim = best + 1e-15 > 0) has a ratio
# above lim even after the division's rounding (the margin is far above the products' rounding),
# so it can neither win nor tie: its division, most of a search's cost, is skipped and the
# choice is the same, bit for bit.
cdef double _RATIO_MARGIN = 1.0 + 1e-12


# The walk comes in two compiled variants, chosen by the type of its last argument (a null
# pointer): _Checked also looks for zero divisors in the loops over the points, which can
# have one only when eps < 0 (the Python callers raise ZeroDivisionError then); _Unchecked does not.
cdef struct _Checked:
    char unused


cdef struct _Unchecked:
    char unused


ctypedef fused _Variant:
    _Checked
    _Unchecked


cdef Py_ssize_t _touch_towards_origin(const double* u, const double* v, const double* z, Py_ssize_t count,
                                      double eps, Py_ssize_t p, double* b, double* c,
                                      _Variant* variant) noexcept nogil:
    """Turn the supporting plane (slopes b, c) about point p alone, lowering the side of the
    origin, until a second point touches it: returns that point (b, c updated), -1 when none
    does (the origin is beyond the points), -3 when p is over the origin, -2 on a zero divisor."""
    cdef double up = u[p]
    cdef double vp = v[p]
    cdef double zp = z[p]
    cdef double r = sqrt(up * up + vp * vp)
    cdef double du, dv, d, t, num, lim = INFINITY, best_t = INFINITY, best_d = 0.0
    cdef Py_ssize_t k, q = -1
    if r <= eps:
        return -3
    if r == 0.0:
        return -2
    du = up / r
    dv = vp / r
    for k in range(count):
        d = (u[k] - up) * du + (v[k] - vp) * dv
        if d < -eps:
            if _Variant is _Checked and d == 0.0:
                return -2
            num = z[k] - (zp + b[0] * (u[k] - up) + c[0] * (v[k] - vp))
            if lim > 0.0 and -num > lim * -d * _RATIO_MARGIN:
                continue  # t = num / d > lim: no better (see _RATIO_MARGIN)
            t = num / d  # >= 0
            if t < best_t - 1e-15 or (t <= best_t + 1e-15 and d < best_d):
                best_t = t
                best_d = d
                q = k
                lim = best_t + 1e-15
    if q >= 0:
        b[0] = b[0] + best_t * du
        c[0] = c[0] + best_t * dv
    return q


cdef int _walk(const double* u, const double* v, const double* z, Py_ssize_t count, double eps, double b0,
               double c0, double* out, bint* tied, _Variant* variant) noexcept nogil:
    """The walk of ``support_plane_from_c`` (see the variants above). Sets ``tied`` where the
    answer may not be the only lowest plane: the origin over a point or an edge of the points'
    upper hull (or within 1e-9 of one, in barycentric weight)."""
    cdef Py_ssize_t p, k, q, w, it
    cdef double zp, up, vp, r, b, c, du, dv, best_t, best_d, d, t
    cdef double eu, ev, el, mu, mv, side, along, s_pos, s_neg, slack, s, best_s, lim
    cdef double ax, ay, bx, by, cx, cy, det, ox, oy, lq, lw, lp
    cdef double tol = -1e-12
    if count == 0:
        out[0] = NAN
        out[1] = NAN
        out[2] = NAN
        return 1
    # start from the plane of slopes (b0, c0) through the point highest above it: a supporting
    # plane (with b0 = c0 = 0, the level plane through the highest point, bit for bit)
    p = 0
    best_t = z[0] - b0 * u[0] - c0 * v[0]
    for k in range(1, count):
        t = z[k] - b0 * u[k] - c0 * v[k]
        if t > best_t:
            p = k
            best_t = t
    zp = z[p]
    up = u[p]
    vp = v[p]
    r = sqrt(up * up + vp * vp)
    b = b0
    c = c0
    if r <= eps:
        out[0] = zp  # the highest point is over the origin: the start plane through it
        out[1] = b0
        out[2] = c0
        tied[0] = True
        return 0
    # rotate the start plane about p, lowering the origin side, until a second point touches
    q = _touch_towards_origin(u, v, z, count, eps, p, &b, &c, variant)
    if q == -2:
        return -1
    if q < 0:
        out[0] = NAN
        out[1] = NAN
        out[2] = NAN
        return 2
    for it in range(_MAX_PIVOTS):
        # rotate about the line p-q
        eu = u[q] - up
        ev = v[q] - vp
        el = sqrt(eu * eu + ev * ev)
        if el == 0.0:
            return -1
        mu = -ev / el
        mv = eu / el
        side = -(mu * up + mv * vp)  # signed distance of the origin from the line along m
        along = -(up * eu + vp * ev) / (el * el)  # where the origin is along p -> q (0 at p, 1 at q)
        if fabs(side) <= eps and not (-1e-12 <= along <= 1.0 + 1e-12):
            # the origin is on the line but beyond the segment: p-q is no edge around it, and
            # turning about the line cannot lower it. Turn about the end nearer it alone, as
            # the first step does (the far end lifts off).
            if along > 1.0:
                p = q
                zp = z[p]
                up = u[p]
                vp = v[p]
            q = _touch_towards_origin(u, v, z, count, eps, p, &b, &c, variant)
            if q == -2:
                return -1
            if q == -3:
                out[0] = zp - b * up - c * vp  # the end is over the origin: resting on it
                out[1] = b
                out[2] = c
                tied[0] = True
                return 0
            if q < 0:
                out[0] = NAN
                out[1] = NAN
                out[2] = NAN
                return 2
            continue
        if fabs(side) <= eps:
            # the origin is on the line: every plane through p and q between the two
            # neighbouring facets is optimal; take the middle one
            s_pos = INFINITY
            s_neg = INFINITY
            for k in range(count):
                d = mu * (u[k] - up) + mv * (v[k] - vp)
                slack = zp + b * (u[k] - up) + c * (v[k] - vp) - z[k]
                if d < -eps:
                    if _Variant is _Checked and d == 0.0:
                        return -1
                    s_pos = _fmin(s_pos, slack / -d)
                elif d > eps:
                    if _Variant is _Checked and d == 0.0:
                        return -1
                    s_neg = _fmin(s_neg, slack / d)
            s = 0.0
            if isfinite(s_pos) and isfinite(s_neg):
                s = 0.5 * (s_pos - s_neg)
            b += s * mu
            c += s * mv
            out[0] = zp - b * up - c * vp
            out[1] = b
            out[2] = c
            tied[0] = True
            return 0
        if side < 0:
            mu = -mu
            mv = -mv  # m points from the line towards the origin
        best_s = INFINITY
        lim = INFINITY
        best_d = 0.0
        w = -1
        for k in range(count):
            d = mu * (u[k] - up) + mv * (v[k] - vp)
            if d > eps:  # on the origin's side: the plane comes down towards it
                slack = zp + b * (u[k] - up) + c * (v[k] - vp) - z[k]
                if slack < 0.0:
                    slack = 0.0
                if _Variant is _Checked and d == 0.0:
                    return -1
                if slack > lim * d * _RATIO_MARGIN:
                    continue  # s = slack / d > lim: no better (see _RATIO_MARGIN)
                s = slack / d
                if s < best_s - 1e-15 or (s <= best_s + 1e-15 and d > best_d):
                    best_s = s
                    best_d = d
                    w = k
                    lim = best_s + 1e-15
        if w < 0:
            out[0] = NAN
            out[1] = NAN
            out[2] = NAN
            return 2
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
        if det == 0.0:
            return -1
        ox = -ax
        oy = -ay
        lq = (ox * cy - oy * cx) / det
        lw = (bx * oy - by * ox) / det
        lp = 1.0 - lq - lw
        if lp >= tol and lq >= tol and lw >= tol:
            out[0] = zp - b * up - c * vp
            out[1] = b
            out[2] = c
            tied[0] = lp < 1e-9 or lq < 1e-9 or lw < 1e-9
            return 0
        # keep the edge that faces the origin: drop the vertex with the most negative weight
        if lp <= lq:
            p = w  # drop p: keep q and w
        else:
            q = w  # drop q: keep p and w
        zp = z[p]
        up = u[p]
        vp = v[p]
    out[0] = NAN
    out[1] = NAN
    out[2] = NAN
    return 2



cdef int support_plane_c(const double* u, const double* v, const double* z, Py_ssize_t count, double eps,
                         double* out) noexcept nogil:
    """Lowest supporting plane over the origin of the first ``count`` points.

    Writes (a, b, c) to ``out``; returns the status: 0 optimal, 1 no points, 2 not converged
    (the origin outside the points' hull, or cycling): callers fall back; -1 a division by
    zero (only when ``eps`` is 0 or negative, or the points underflow), where the Python-level
    callers raise ZeroDivisionError (``out`` is then not written).
    ``eps`` is the length below which xy distances count as zero.
    """
    cdef bint tied = False
    if eps >= 0.0:
        return _walk(u, v, z, count, eps, 0.0, 0.0, out, &tied, <_Unchecked*>NULL)  # d beyond +-eps is never zero
    return _walk(u, v, z, count, eps, 0.0, 0.0, out, &tied, <_Checked*>NULL)


cdef int support_plane_from_c(const double* u, const double* v, const double* z, Py_ssize_t count, double eps,
                              double b0, double c0, double* out) noexcept nogil:
    """``support_plane_c``, the walk starting from the plane of slopes (b0, c0) instead of the
    level one: fewer pivots when the start is near the answer, and the same plane (to rounding).
    Where several planes are lowest (the origin over an edge or a point of the points' upper
    hull) the start could choose among them, so there the walk is made again from level."""
    cdef bint tied = False
    cdef int st
    if eps >= 0.0:
        st = _walk(u, v, z, count, eps, b0, c0, out, &tied, <_Unchecked*>NULL)  # d beyond +-eps is never zero
    else:
        st = _walk(u, v, z, count, eps, b0, c0, out, &tied, <_Checked*>NULL)
    if st != 0 or tied:
        return support_plane_c(u, v, z, count, eps, out)
    return st


def support_plane(u, v, z, count, double eps, start=None):
    """Lowest supporting plane over the origin of the first ``count`` points.

    Returns (a, b, c, status): status 0 optimal, 1 no points, 2 not converged
    (the origin outside the points' hull, or cycling): callers fall back.
    ``eps`` is the length below which xy distances count as zero. ``start``: slopes (b, c)
    to start the walk from (``support_plane_from_c``), instead of level.
    """
    cdef const double[::1] uu = np.ascontiguousarray(u, dtype=np.float64)
    cdef const double[::1] vv = np.ascontiguousarray(v, dtype=np.float64)
    cdef const double[::1] zz = np.ascontiguousarray(z, dtype=np.float64)
    cdef Py_ssize_t n = count
    if n < 0 or n > uu.shape[0] or n > vv.shape[0] or n > zz.shape[0]:
        raise ValueError(f"count {n} outside the points given ({uu.shape[0]}, {vv.shape[0]}, {zz.shape[0]})")
    cdef double out[3]
    cdef int st
    cdef double b0 = 0.0
    cdef double c0 = 0.0
    if start is not None:
        b0, c0 = float(start[0]), float(start[1])
    with nogil:
        if start is None:
            st = support_plane_c(&uu[0], &vv[0], &zz[0], n, eps, out)
        else:
            st = support_plane_from_c(&uu[0], &vv[0], &zz[0], n, eps, b0, c0, out)
    if st < 0:
        raise ZeroDivisionError("division by zero")
    return out[0], out[1], out[2], st


def support_planes_fixed(u, v, z, double eps):
    """``support_plane`` for many poses sharing the same point layout.

    u, v : (k,) point positions in the heading frame; z : (N, k) heights.
    Returns planes (N, 3) and status (N,).
    """
    cdef const double[::1] uu = np.ascontiguousarray(u, dtype=np.float64)
    cdef const double[::1] vv = np.ascontiguousarray(v, dtype=np.float64)
    cdef const double[:, ::1] zz = np.ascontiguousarray(z, dtype=np.float64)
    cdef Py_ssize_t k = uu.shape[0]
    cdef Py_ssize_t n = zz.shape[0]
    if vv.shape[0] < k or (n > 0 and zz.shape[1] < k):
        raise ValueError(f"{k} points but v has {vv.shape[0]} and z rows have {zz.shape[1]}")
    out_arr = np.empty((n, 3))
    status_arr = np.empty(n, np.int64)
    cdef double[:, ::1] out = out_arr
    cdef int64_t[::1] status = status_arr
    cdef Py_ssize_t i
    cdef int zero_division = 0
    cdef int* zero_flag = &zero_division
    with nogil:
        for i in prange(n, schedule="static"):
            status[i] = support_plane_c(&uu[0], &vv[0], &zz[i, 0], k, eps, &out[i, 0])
            if status[i] < 0:
                zero_flag[0] = 1
    if zero_division:
        raise ZeroDivisionError("division by zero")
    return out_arr, status_arr
