# cython: language_level=3
"""The broad phase's sort and sweep, compiled (``collision.broad_phase.sort_and_sweep``'s method;
its oracle is ``collision.broad_phase.brute_force``, every pair tested, which the tests hold it to
array for array): the segments in the order of their starts on one axis, each one's partners the
segments after it that start at or before its end, tested on the other axes and the owners as
they are met. Only the input floats are compared (closed intervals), never differences of them,
as in every method."""

import numpy as np

cimport numpy as cnp
from libc.stdint cimport int64_t

cnp.import_array()


def sweep_keys(const double[:, ::1] L, const double[:, ::1] H, const int64_t[::1] own, const int64_t[::1] order,
               int axis, const int64_t[::1] others):
    """Pair keys min * M + max (int64, unsorted) of the segments ``order`` (indices into L, H, own,
    sorted by L[:, axis], ties in any order) among themselves: closed boxes (M, 4) L, H in
    (x, y, z, t) overlapping on every axis, owners different. ``others``: the other three axes, the
    most selective first (the order tests are made in; the answer does not depend on it)."""
    cdef Py_ssize_t m = L.shape[0]
    cdef Py_ssize_t n = order.shape[0]
    cdef Py_ssize_t a, b, cap = 1024, used = 0
    cdef int64_t i, j
    cdef int o0 = <int>others[0], o1 = <int>others[1], o2 = <int>others[2]
    cdef double end
    out_arr = np.empty(cap, dtype=np.int64)
    cdef int64_t[::1] out = out_arr
    for a in range(n):
        i = order[a]
        end = H[i, axis]
        for b in range(a + 1, n):
            j = order[b]
            if L[j, axis] > end:
                break
            if own[i] == own[j]:
                continue
            if not (L[i, o0] <= H[j, o0] and L[j, o0] <= H[i, o0]):
                continue
            if not (L[i, o1] <= H[j, o1] and L[j, o1] <= H[i, o1]):
                continue
            if not (L[i, o2] <= H[j, o2] and L[j, o2] <= H[i, o2]):
                continue
            if used == cap:
                cap *= 2
                grown = np.empty(cap, dtype=np.int64)
                grown[:used] = out_arr[:used]
                out_arr = grown
                out = out_arr
            out[used] = (i * m + j) if i < j else (j * m + i)
            used += 1
    return out_arr[:used]
