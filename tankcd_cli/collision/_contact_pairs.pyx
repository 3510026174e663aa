# cython: language_level=3
"""The triangle pairs of first contacts between two placed bodies: for each contact, every pair of
triangles whose boxes come within ``reach`` of each other, after shrinking each side to the box of
the other's near triangles (``collision.vehicles.contact_centres``; its numpy twin is
``collision.contact_pairs.near_triangle_pairs_numpy``, which the tests compare pair for pair)."""

import numpy as np

cimport numpy as cnp
from libc.math cimport INFINITY

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


def near_triangle_pairs(const double[:, :, :, :] A, const double[:, :, :, :] B, double reach, int rounds=3):
    """For K contacts, body a's placed triangles A (K, ma, 3, 3) and body b's B (K, mb, 3, 3), m:
    (owner, ia, ib) int64 each, every pair (ia, ib) of contact ``owner`` whose boxes come within
    ``reach`` (m) on every axis, after ``rounds`` rounds of keeping each side's triangles within
    ``reach`` of the box of the other's kept ones; in contact order, then ia, then ib (np.nonzero's)."""
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
