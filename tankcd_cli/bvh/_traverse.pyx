"""Tandem depth-first traversal of two trees, batched over poses, compiled ahead of time (Cython).

See :mod:`tankcd_cli.bvh.traverse` for the method. Poses run in OpenMP threads, handed out
dynamically in chunks of ``POSE_CHUNK`` (a clear pose ends at the roots, a grazing one goes
deep); within a pose the walk is sequential, its arithmetic in one fixed order, so results
do not depend on the thread count.
"""

cimport numpy as cnp
from cython.parallel cimport parallel, prange
from libc.math cimport fabs, INFINITY
from libc.stdint cimport int64_t
from libc.stdlib cimport free, malloc

import numpy as np

cnp.import_array()

from tankcd_cli.geometry.arrays import f64 as _f64, i64 as _i64

from tankcd_cli.bvh._trees cimport Trees, fill_trees, nodes_disjoint, tree_reach
from tankcd_cli.geometry._triangles cimport tri_tri_c

FIRST, ALL = 0, 1
cdef int64_t _FIRST = 0
POSE_CHUNK = 8  # poses handed to a thread at a time by collide_batch


cdef int64_t _walk(const double* R, const double* tv, const double* f, const double* g, const double* shift,
                   const Trees* tr, int64_t mode, int64_t* pairs, double* points, Py_ssize_t cap,
                   int64_t* stack, double tol, int64_t* node_tests_out, int64_t* tri_tests_out) noexcept nogil:
    """One pose: contacts found; pairs (cap, 2) and points (cap, 3) receive the first ``cap``."""
    cdef int64_t node_tests = 0
    cdef int64_t tri_tests = 0
    cdef int64_t found = 0
    cdef double P[9]
    cdef double out[3]
    cdef double scratch[18]
    cdef Py_ssize_t sp, v, m
    cdef int64_t a, b, ta, tb
    cdef bint a_leaf, b_leaf
    cdef const double* at
    stack[0] = 0
    stack[1] = 0
    sp = 1
    while sp > 0:
        sp -= 1
        a = stack[2 * sp]
        b = stack[2 * sp + 1]
        node_tests += 1
        if nodes_disjoint(tr, a, b, f, g, shift, tol):
            continue
        a_leaf = tr.a_left[a] < 0
        b_leaf = tr.b_left[b] < 0
        if a_leaf and b_leaf:
            for ta in range(tr.a_start[a], tr.a_start[a] + tr.a_count[a]):
                at = tr.a_tri + ta * 9
                for v in range(3):
                    for m in range(3):
                        P[3 * v + m] = (R[3 * m] * at[3 * v] + R[3 * m + 1] * at[3 * v + 1]
                                        + R[3 * m + 2] * at[3 * v + 2] + tv[m])
                for tb in range(tr.b_start[b], tr.b_start[b] + tr.b_count[b]):
                    tri_tests += 1
                    if tri_tri_c(P, tr.b_tri + tb * 9, out, scratch):
                        if found < cap:
                            pairs[2 * found] = tr.a_idx[ta]
                            pairs[2 * found + 1] = tr.b_idx[tb]
                            points[3 * found] = out[0]
                            points[3 * found + 1] = out[1]
                            points[3 * found + 2] = out[2]
                        found += 1
                        if mode == _FIRST:
                            node_tests_out[0] = node_tests
                            tri_tests_out[0] = tri_tests
                            return found
            continue
        if b_leaf or (not a_leaf and tr.a_size[a] >= tr.b_size[b]):
            stack[2 * sp] = tr.a_left[a]
            stack[2 * sp + 1] = b
            stack[2 * sp + 2] = tr.a_right[a]
            stack[2 * sp + 3] = b
        else:
            stack[2 * sp] = a
            stack[2 * sp + 1] = tr.b_left[b]
            stack[2 * sp + 2] = a
            stack[2 * sp + 3] = tr.b_right[b]
        sp += 2
    node_tests_out[0] = node_tests
    tri_tests_out[0] = tri_tests
    return found


cdef void _pose(Py_ssize_t p, const double* R, const double* tv, const double* D, const double* W,
                const Trees* tr, int64_t mode, double reach, Py_ssize_t cap, double* f, double* g,
                double* shift, int64_t* stack, int64_t* found, int64_t* pairs, double* points,
                int64_t* node_tests, int64_t* tri_tests) noexcept nogil:
    """Pose p of collide_batch, with the thread's work arrays f (K, 3), g (T, K, 3), shift (K,), stack."""
    cdef Py_ssize_t K = tr.K
    cdef Py_ssize_t T = tr.T
    cdef Py_ssize_t i, j, t
    cdef const double* Rp = R + 9 * p
    cdef const double* tp = tv + 3 * p
    for i in range(K):
        for j in range(3):
            f[3 * i + j] = D[3 * i] * Rp[j] + D[3 * i + 1] * Rp[3 + j] + D[3 * i + 2] * Rp[6 + j]
    for t in range(T):
        for i in range(K):
            for j in range(3):
                g[(t * K + i) * 3 + j] = (f[3 * i] * W[9 * t + j] + f[3 * i + 1] * W[9 * t + 3 + j]
                                          + f[3 * i + 2] * W[9 * t + 6 + j])
    for i in range(K):
        shift[i] = D[3 * i] * tp[0] + D[3 * i + 1] * tp[1] + D[3 * i + 2] * tp[2]
    # volumes are compared with a margin of round-off, so that exactly touching shapes are never
    # dropped before their triangles (which count touching as contact) are tested
    cdef double scale = fabs(tp[0]) + fabs(tp[1]) + fabs(tp[2]) + reach
    found[p] = _walk(Rp, tp, f, g, shift, tr, mode, pairs + 2 * cap * p, points + 3 * cap * p, cap, stack,
                     1e-12 * scale, node_tests + p, tri_tests + p)


def collide_batch(R, tv, D, W, a, b, mode, max_contacts):
    """Walk A at every pose (R (N, 3, 3), t (N, 3)) against B.

    a, b : the moving and the static tree (``bvh.build.Tree``: the arrays are read from it);
    D, W : the k-DOP directions and the inverses of their triples.

    Returns contacts found per pose (N,) (all of them in mode ALL, 0 or 1 in
    FIRST), the first ``max_contacts`` pairs (N, c, 2) of input triangle
    indices and their contact points (N, c, 3), and the node-pair and
    triangle-pair tests made (N,).
    """
    cdef const double[:, :, ::1] R_ = _f64(R)
    cdef const double[:, ::1] tv_ = _f64(tv)
    cdef const double[:, ::1] D_ = _f64(D)
    cdef const double[:, :, ::1] W_ = _f64(W)
    cdef Py_ssize_t n = R_.shape[0]
    cdef Py_ssize_t K = D_.shape[0]
    cdef Py_ssize_t T = W_.shape[0]
    cdef Py_ssize_t cap = max(max_contacts, 1)
    cdef int64_t mode_ = mode
    found_arr = np.zeros(n, np.int64)
    node_arr = np.zeros(n, np.int64)
    tri_arr = np.zeros(n, np.int64)
    pairs_arr = np.full((n, cap, 2), -1, np.int64)
    points_arr = np.full((n, cap, 3), np.nan)
    cdef int64_t[::1] found = found_arr
    cdef int64_t[::1] node_tests = node_arr
    cdef int64_t[::1] tri_tests = tri_arr
    cdef int64_t[:, :, ::1] pairs = pairs_arr
    cdef double[:, :, ::1] points = points_arr
    cdef Trees tr
    keep = fill_trees(&tr, a, b, K, T)
    cdef Py_ssize_t depth = int(np.max(keep[6]) + np.max(keep[18]) + 4)
    cdef Py_ssize_t i, p
    cdef double reach = tree_reach(&tr)
    if n == 0:
        return found_arr, pairs_arr, points_arr, node_arr, tri_arr
    cdef const double* Rp = &R_[0, 0, 0]
    cdef const double* tp = &tv_[0, 0]
    cdef const double* Dp = &D_[0, 0] if K else NULL
    cdef const double* Wp = &W_[0, 0, 0] if T else NULL
    cdef int64_t* found_p = &found[0]
    cdef int64_t* node_p = &node_tests[0]
    cdef int64_t* tri_p = &tri_tests[0]
    cdef int64_t* pairs_p = &pairs[0, 0, 0]
    cdef double* points_p = &points[0, 0, 0]
    cdef Py_ssize_t stack_len = 2 * (2 * depth + 2)
    cdef double* f = NULL  # each thread's own (the parallel block makes them private)
    cdef double* g = NULL
    cdef double* shift = NULL
    cdef int64_t* stack = NULL
    cdef int failed = 0
    cdef int* failed_p = &failed  # written through the pointer: shared, not a private of the loop
    with nogil, parallel():
        f = <double*>malloc((3 * K + 1) * sizeof(double))
        g = <double*>malloc((3 * K * T + 1) * sizeof(double))
        shift = <double*>malloc((K + 1) * sizeof(double))
        stack = <int64_t*>malloc(stack_len * sizeof(int64_t))
        for p in prange(n, schedule="dynamic", chunksize=8):  # POSE_CHUNK
            if f == NULL or g == NULL or shift == NULL or stack == NULL:
                failed_p[0] = 1
            else:
                _pose(p, Rp, tp, Dp, Wp, &tr, mode_, reach, cap, f, g, shift, stack, found_p, pairs_p,
                      points_p, node_p, tri_p)
        free(f)
        free(g)
        free(shift)
        free(stack)
    if failed:
        raise MemoryError("collide_batch: no memory for a thread's work arrays")
    return found_arr, pairs_arr, points_arr, node_arr, tri_arr


cdef int64_t _brute_pose(const double* R, const double* tv, const double* a_tri, Py_ssize_t na,
                         const double* b_tri, Py_ssize_t nb, int64_t mode) noexcept nogil:
    cdef double P[9]
    cdef double out[3]
    cdef double scratch[18]
    cdef int64_t found = 0
    cdef Py_ssize_t ta, tb, v, m
    cdef const double* at
    for ta in range(na):
        at = a_tri + 9 * ta
        for v in range(3):
            for m in range(3):
                P[3 * v + m] = (R[3 * m] * at[3 * v] + R[3 * m + 1] * at[3 * v + 1]
                                + R[3 * m + 2] * at[3 * v + 2] + tv[m])
        for tb in range(nb):
            if tri_tri_c(P, b_tri + 9 * tb, out, scratch):
                found += 1
                if mode == _FIRST:
                    break
        if mode == _FIRST and found:
            break
    return found


def brute_force_batch(R, tv, a_tri, b_tri, mode):
    """Every triangle pair at every pose: contacts found (N,) (the oracle of the trees)."""
    cdef const double[:, :, ::1] R_ = _f64(R)
    cdef const double[:, ::1] tv_ = _f64(tv)
    cdef const double[:, :, ::1] a_ = _f64(a_tri)
    cdef const double[:, :, ::1] b_ = _f64(b_tri)
    cdef Py_ssize_t n = R_.shape[0]
    cdef Py_ssize_t na = a_.shape[0]
    cdef Py_ssize_t nb = b_.shape[0]
    cdef int64_t mode_ = mode
    found_arr = np.zeros(n, np.int64)
    cdef int64_t[::1] found = found_arr
    cdef Py_ssize_t p
    if n == 0 or na == 0 or nb == 0:
        return found_arr
    cdef const double* Rp = &R_[0, 0, 0]
    cdef const double* tp = &tv_[0, 0]
    cdef const double* ap = &a_[0, 0, 0]
    cdef const double* bp = &b_[0, 0, 0]
    cdef int64_t* found_p = &found[0]
    for p in prange(n, nogil=True, schedule="dynamic"):
        found_p[p] = _brute_pose(Rp + 9 * p, tp + 3 * p, ap, na, bp, nb, mode_)
    return found_arr
