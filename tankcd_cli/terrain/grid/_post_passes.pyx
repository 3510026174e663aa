"""Compiled twins of the per-post passes of ``grid.tiled_classify`` (see
:mod:`tankcd_cli.terrain.grid.post_passes`), compiled ahead of time (Cython).

The operations and their order are the numpy twins': the same bits. Both passes run without
the GIL (``tiled_classify`` calls them from worker threads) and serially (those threads are the
parallelism).
"""

import numpy as np

from libc.math cimport isfinite, sqrt

ctypedef fused real_t:
    float
    double


def _heights(z):
    """float32 stays float32 (its first differences are taken in float32); anything else float64."""
    a = np.asarray(z)
    if a.ndim != 2:
        raise ValueError(f"z must be 2-D (rows, cols), got {a.ndim}-D")
    if a.dtype == np.float32:
        return np.ascontiguousarray(a)
    return np.ascontiguousarray(a, dtype=np.float64)


cdef void _fd(const real_t[:, ::1] z, double hx, double hy, double ixx, double iyy, double ixy,
              double[:, ::1] H) noexcept nogil:
    cdef Py_ssize_t rows = z.shape[0]
    cdef Py_ssize_t cols = z.shape[1]
    cdef Py_ssize_t r, c
    cdef real_t cc, n, s, e, w
    cdef double fx, fy, fxx, fyy, fxy, fx2, fy2, g
    for r in range(1, rows - 1):
        for c in range(1, cols - 1):
            cc = z[r, c]
            n = z[r - 1, c]
            s = z[r + 1, c]
            e = z[r, c + 1]
            w = z[r, c - 1]
            fx = (e - w) * hx  # e - w in the heights' precision
            fy = (n - s) * hy
            fxx = (<double>e - 2.0 * <double>cc + <double>w) * ixx  # second differences in float64
            fyy = (<double>n - 2.0 * <double>cc + <double>s) * iyy
            fxy = ((z[r - 1, c + 1] - z[r - 1, c - 1]) - (z[r + 1, c + 1] - z[r + 1, c - 1])) * ixy
            fx2 = fx * fx
            fy2 = fy * fy
            g = 1.0 + fx2 + fy2
            H[r, c] = -((1.0 + fy2) * fxx - 2.0 * fx * fy * fxy + (1.0 + fx2) * fyy) / (2.0 * g * sqrt(g))


def fd_mean_curvature(z, double dx, double dy):
    """``tiled_classify.grid_mean_curvature_fd``: H by central differences (NaN on the border and where a
    neighbour is missing); z (rows, cols) row 0 north."""
    za = _heights(z)
    H_arr = np.full(za.shape, np.nan)
    # a zero spacing (or one whose square underflows) has no differences: ZeroDivisionError
    if dx == 0.0 or dy == 0.0 or dx * dx == 0.0 or dy * dy == 0.0 or dx * dy == 0.0:
        raise ZeroDivisionError("division by zero")
    cdef double hx = 0.5 / dx
    cdef double hy = 0.5 / dy
    cdef double ixx = 1.0 / (dx * dx)
    cdef double iyy = 1.0 / (dy * dy)
    cdef double ixy = 0.25 / (dx * dy)
    cdef double[:, ::1] H = H_arr
    cdef const float[:, ::1] z32
    cdef const double[:, ::1] z64
    if za.dtype == np.float32:
        z32 = za
        with nogil:
            _fd(z32, hx, hy, ixx, iyy, ixy, H)
    else:
        z64 = za
        with nogil:
            _fd(z64, hx, hy, ixx, iyy, ixy, H)
    return H_arr


cdef inline double _area(double ax, double ay, double bx, double by, double az, double bz) noexcept nogil:
    cdef double cx = ay * bz - az * by
    cdef double cy = az * bx - ax * bz
    cdef double cz = ax * by - ay * bx
    return 0.5 * sqrt(cx * cx + cy * cy + cz * cz)


cdef inline double _corner_area(int i, int j, int k, const double* x, const double* y,
                                const double* zz) noexcept nogil:
    return _area(x[j] - x[i], y[j] - y[i], x[k] - x[i], y[k] - y[i], zz[j] - zz[i], zz[k] - zz[i])


cdef void _post_areas(const double[:, ::1] z, double dx, double dy, double[:, ::1] a) noexcept nogil:
    """Per cell its corner shares (SW, SE, NE, NW), added where the numpy twin's four passes
    (every SW share, then SE, NE, NW) put them, in that order per post: a cell's SE share goes
    to the post east of its SW one after that post's own SW share, so it waits one cell."""
    cdef Py_ssize_t rows = z.shape[0]
    cdef Py_ssize_t cols = z.shape[1]
    cdef Py_ssize_t r, c
    cdef double x[4]
    cdef double y[4]
    cdef double zz[4]
    cdef double v[4]
    cdef bint ok[4]
    cdef int k, count
    cdef double t, t1, t2, s0, s1, s2, s3, pending
    x[0] = 0.0
    x[1] = dx
    x[2] = dx
    x[3] = 0.0
    y[0] = 0.0
    y[1] = 0.0
    y[2] = dy
    y[3] = dy
    for r in range(rows - 1):
        pending = 0.0  # the previous cell's SE share, for post (r + 1, c)
        for c in range(cols - 1):
            v[0] = z[r + 1, c]  # SW
            v[1] = z[r + 1, c + 1]  # SE
            v[2] = z[r, c + 1]  # NE
            v[3] = z[r, c]  # NW
            count = 0
            for k in range(4):
                ok[k] = isfinite(v[k])
                zz[k] = v[k] if ok[k] else 0.0
                count += ok[k]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            if count == 4:
                t1 = _corner_area(0, 1, 2, x, y, zz) / 3.0
                t2 = _corner_area(0, 2, 3, x, y, zz) / 3.0
                s0 = t1 + t2
                s1 = t1
                s2 = t1 + t2
                s3 = t2
            elif count == 3:
                if not ok[0]:
                    t = _corner_area(1, 2, 3, x, y, zz) / 3.0
                elif not ok[1]:
                    t = _corner_area(0, 2, 3, x, y, zz) / 3.0
                elif not ok[2]:
                    t = _corner_area(0, 1, 3, x, y, zz) / 3.0
                else:
                    t = _corner_area(0, 1, 2, x, y, zz) / 3.0
                if ok[0]:
                    s0 = t
                if ok[1]:
                    s1 = t
                if ok[2]:
                    s2 = t
                if ok[3]:
                    s3 = t
            # post (r + 1, c): SW share of this cell, then SE share of the cell to the west
            a[r + 1, c] += s0
            if c > 0:
                a[r + 1, c] += pending
            pending = s1
            # post (r, c + 1): NE share of this cell (after its SW and SE shares, from row r - 1)
            a[r, c + 1] += s2
            # post (r, c): NW share of this cell, its last (the NE share came from the cell to the west)
            a[r, c] += s3
        if cols > 1:
            a[r + 1, cols - 1] += pending


def post_areas(z, double dx, double dy):
    """``tiled_classify.post_areas``: a third of the 3-D area of each triangle at every post."""
    za = np.asarray(z)
    if za.ndim != 2:
        raise ValueError(f"z must be 2-D (rows, cols), got {za.ndim}-D")
    cdef const double[:, ::1] zv = np.ascontiguousarray(za, dtype=np.float64)  # exact for any float input
    if zv.shape[0] < 1 or zv.shape[1] < 1:
        raise ValueError("negative dimensions not allowed")  # an empty raster has no cells (rows - 1 < 0)
    a_arr = np.zeros((zv.shape[0], zv.shape[1]))
    cdef double[:, ::1] a = a_arr
    with nogil:
        _post_areas(zv, dx, dy, a)
    return a_arr
