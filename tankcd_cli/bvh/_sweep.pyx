"""Continuous tandem traversal: the first contact of two trees along rigid, articulated motions.

See :mod:`tankcd_cli.bvh.sweep` for the method and its proof. Queries run in OpenMP threads
(dynamic schedule: a clear query ends at one walk, a grazing one bisects deep); within a query
the bisection over time is sequential, earliest half first.

A motion row holds 30 doubles: the hull's start quaternion (qw, qx, qy, qz) and origin (3),
its end quaternion and origin, then up to two joints, each a point (3), a unit axis (3), a
start angle and its change (rad). The body's placement at fraction s is
G(s) = H(s) o J1(s) o J2(s): H the slerp of the quaternions and the lerp of the origins, J_k
the turn by angle0 + s * change about the joint's axis through its point.
"""

cimport numpy as cnp
from cython.parallel cimport parallel, prange
from libc.math cimport acos, fabs, sin, cos, sqrt, INFINITY
from libc.stdint cimport int64_t
from libc.stdlib cimport free, malloc

import numpy as np

from tankcd_cli.bvh._trees cimport Trees, fill_trees, nodes_disjoint, tree_reach
from tankcd_cli.geometry._triangles cimport tri_tri_distance_c

cdef extern from "_omp_shim.h":
    int tcd_max_threads() nogil

cnp.import_array()

MOTION_WIDTH = 30
cdef enum:
    DEPTH_LIMIT = 60  # bisection levels at most (a level halves the time step)
LEVEL_LIMIT = DEPTH_LIMIT


cdef void _quat_matrix(double w, double x, double y, double z, double* R) noexcept nogil:
    R[0] = 1 - 2 * (y * y + z * z)
    R[1] = 2 * (x * y - w * z)
    R[2] = 2 * (x * z + w * y)
    R[3] = 2 * (x * y + w * z)
    R[4] = 1 - 2 * (x * x + z * z)
    R[5] = 2 * (y * z - w * x)
    R[6] = 2 * (x * z - w * y)
    R[7] = 2 * (y * z + w * x)
    R[8] = 1 - 2 * (x * x + y * y)


cdef void _axis_matrix(const double* u, double a, double* R) noexcept nogil:
    """Turn by a about unit axis u (Rodrigues)."""
    cdef double c = cos(a)
    cdef double s = sin(a)
    cdef double k = 1 - c
    R[0] = c + k * u[0] * u[0]
    R[1] = k * u[0] * u[1] - s * u[2]
    R[2] = k * u[0] * u[2] + s * u[1]
    R[3] = k * u[1] * u[0] + s * u[2]
    R[4] = c + k * u[1] * u[1]
    R[5] = k * u[1] * u[2] - s * u[0]
    R[6] = k * u[2] * u[0] - s * u[1]
    R[7] = k * u[2] * u[1] + s * u[0]
    R[8] = c + k * u[2] * u[2]


cdef void _mul(const double* A, const double* B, double* C) noexcept nogil:
    """C = A B (3 x 3, row-major); C may not alias A or B."""
    cdef int i, j
    for i in range(3):
        for j in range(3):
            C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j]


cdef void _apply(const double* R, const double* t, const double* p, double* out) noexcept nogil:
    cdef int i
    for i in range(3):
        out[i] = R[3 * i] * p[0] + R[3 * i + 1] * p[1] + R[3 * i + 2] * p[2] + t[i]


cdef void chain_at(const double* m, int64_t joints, double s, double* R, double* t) noexcept nogil:
    """The placement (R, t) at fraction s of motion row m (see the module's docstring)."""
    cdef double q0w = m[0], q0x = m[1], q0y = m[2], q0z = m[3]
    cdef double q1w = m[7], q1x = m[8], q1y = m[9], q1z = m[10]
    cdef double dot = q0w * q1w + q0x * q1x + q0y * q1y + q0z * q1z
    if dot < 0:
        q1w, q1x, q1y, q1z, dot = -q1w, -q1x, -q1y, -q1z, -dot
    if dot > 1.0:
        dot = 1.0
    cdef double angle = acos(dot)
    cdef double sn = sin(angle)
    cdef double w0, w1
    if sn < 1e-12:
        w0, w1 = 1 - s, s
    else:
        w0 = sin((1 - s) * angle) / sn
        w1 = sin(s * angle) / sn
    cdef double qw = w0 * q0w + w1 * q1w
    cdef double qx = w0 * q0x + w1 * q1x
    cdef double qy = w0 * q0y + w1 * q1y
    cdef double qz = w0 * q0z + w1 * q1z
    cdef double norm = sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    cdef double H[9]
    _quat_matrix(qw / norm, qx / norm, qy / norm, qz / norm, H)
    cdef double X[9]
    cdef double Y[9]
    cdef double J[9]
    cdef double tx[3]
    cdef double ty[3]
    cdef int i, k
    cdef const double* jt
    for i in range(9):
        X[i] = 1.0 if i % 4 == 0 else 0.0
    for i in range(3):
        tx[i] = 0.0
    # X = J_k o X for the last joint first: the chain applies J2, then J1, then the hull
    for k in range(joints - 1, -1, -1):
        jt = m + 14 + 8 * k
        _axis_matrix(jt + 3, jt[6] + s * jt[7], J)
        _mul(J, X, Y)
        for i in range(3):
            ty[i] = (J[3 * i] * (tx[0] - jt[0]) + J[3 * i + 1] * (tx[1] - jt[1]) + J[3 * i + 2] * (tx[2] - jt[2])
                     + jt[i])
        for i in range(9):
            X[i] = Y[i]
        for i in range(3):
            tx[i] = ty[i]
    _mul(H, X, R)
    for i in range(3):
        t[i] = H[3 * i] * tx[0] + H[3 * i + 1] * tx[1] + H[3 * i + 2] * tx[2] + (m[4 + i] + s * (m[11 + i] - m[4 + i]))


cdef bint _walk_within(const double* R, const double* tv, const double* f, const double* g, const double* shift,
                       const Trees* tr, double r, double tol, int64_t* stack, int64_t* pair, double* cp,
                       double* cq, int64_t* node_tests) noexcept nogil:
    """Whether some triangle of A (moved by x -> R x + t into B's frame) lies within r of one of
    B's; the first such pair found and its closest points (B's frame) are written out.

    A pair of nodes is dropped when their volumes are more than r + tol apart along a slab
    direction (unit directions: a volume grown by a ball of radius r grows by r in each slab)."""
    cdef Py_ssize_t sp, v, m
    cdef int64_t a, b, ta, tb
    cdef bint disjoint, a_leaf, b_leaf
    cdef double d
    cdef double P[9]
    cdef double scratch[18]
    cdef double lo[3]
    cdef double hi[3]
    cdef const double* at
    cdef const double* bt
    cdef double margin = r + tol
    stack[0] = 0
    stack[1] = 0
    sp = 1
    while sp > 0:
        sp -= 1
        a = stack[2 * sp]
        b = stack[2 * sp + 1]
        node_tests[0] += 1
        if nodes_disjoint(tr, a, b, f, g, shift, margin):
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
                for m in range(3):
                    lo[m] = P[m] if P[m] < P[3 + m] else P[3 + m]
                    lo[m] = lo[m] if lo[m] < P[6 + m] else P[6 + m]
                    hi[m] = P[m] if P[m] > P[3 + m] else P[3 + m]
                    hi[m] = hi[m] if hi[m] > P[6 + m] else P[6 + m]
                for tb in range(tr.b_start[b], tr.b_start[b] + tr.b_count[b]):
                    bt = tr.b_tri + tb * 9
                    disjoint = False
                    for m in range(3):  # the triangles' boxes, grown by the margin, first
                        if (lo[m] > bt[m] + margin and lo[m] > bt[3 + m] + margin and lo[m] > bt[6 + m] + margin) \
                                or (hi[m] < bt[m] - margin and hi[m] < bt[3 + m] - margin
                                    and hi[m] < bt[6 + m] - margin):
                            disjoint = True
                            break
                    if disjoint:
                        continue
                    d = tri_tri_distance_c(P, bt, cp, cq, scratch)
                    if d <= r + tol:
                        pair[0] = tr.a_idx[ta]
                        pair[1] = tr.b_idx[tb]
                        return True
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
    return False


cdef void _relative(const double* Ra, const double* ta, const double* Rb, const double* tb, double* R,
                    double* t) noexcept nogil:
    """(R, t) = G_b^-1 o G_a: A's placement seen in B's frame."""
    cdef int i, j
    for i in range(3):
        for j in range(3):
            R[3 * i + j] = Rb[i] * Ra[j] + Rb[3 + i] * Ra[3 + j] + Rb[6 + i] * Ra[6 + j]
        t[i] = Rb[i] * (ta[0] - tb[0]) + Rb[3 + i] * (ta[1] - tb[1]) + Rb[6 + i] * (ta[2] - tb[2])


cdef void _frame(const double* R, const double* tp, const double* D, const double* W, Py_ssize_t K, Py_ssize_t T,
                 double* f, double* g, double* shift) noexcept nogil:
    """The walk's slab frame of a placement: f (K, 3), g (T, K, 3), shift (K,) (as collide_batch's)."""
    cdef Py_ssize_t i, j, t
    for i in range(K):
        for j in range(3):
            f[3 * i + j] = D[3 * i] * R[j] + D[3 * i + 1] * R[3 + j] + D[3 * i + 2] * R[6 + j]
    for t in range(T):
        for i in range(K):
            for j in range(3):
                g[(t * K + i) * 3 + j] = (f[3 * i] * W[9 * t + j] + f[3 * i + 1] * W[9 * t + 3 + j]
                                          + f[3 * i + 2] * W[9 * t + 6 + j])
    for i in range(K):
        shift[i] = D[3 * i] * tp[0] + D[3 * i + 1] * tp[1] + D[3 * i + 2] * tp[2]


cdef void _query(Py_ssize_t q, const double* ma, const int64_t* ja, const double* mb, const int64_t* jb,
                 const double* rate, const double* before, double eps, const double* D, const double* W,
                 const Trees* tr, double reach,
                 double* f, double* g, double* shift, int64_t* stack, double* span, int64_t* level_of,
                 int64_t* found, double* s_out, int64_t* pairs, double* points, int64_t* node_tests,
                 int64_t* levels) noexcept nogil:
    """Query q: the earliest leaf of the bisection over [0, 1] at which A comes within its motion
    bound of B (see bvh.sweep). The bisection's own stack holds at most DEPTH_LIMIT + 2 intervals:
    their ends in span, their levels in level_of; ``stack`` is the walk's.

    An interval that can only report at or after ``before[q]`` is dropped unwalked: one starting
    there (its leaves' middles lie after its start), or a leaf-to-be whose middle is there. The
    earliest leaf, if it lies before ``before[q]``, starts before it, and so do all its ancestors:
    it is reached and reported as without the bound; otherwise what is reported (or not) lies at
    or after the bound as well."""
    cdef Py_ssize_t K = tr.K
    cdef Py_ssize_t T = tr.T
    cdef const double* mqa = ma + 30 * q
    cdef const double* mqb = mb + 30 * q
    cdef double Ra[9]
    cdef double Rb[9]
    cdef double R[9]
    cdef double ta[3]
    cdef double tb[3]
    cdef double t[3]
    cdef double cp[3]
    cdef double cq[3]
    cdef int64_t pair[2]
    cdef double lo, hi, mid, half, r, scale
    cdef Py_ssize_t sp = 1
    cdef int64_t depth
    cdef int64_t deepest = 0
    cdef int i
    span[0] = 0.0
    span[1] = 1.0
    level_of[0] = 0
    found[q] = 0
    s_out[q] = -1.0
    node_tests[q] = 0
    while sp > 0:
        sp -= 1
        lo = span[2 * sp]
        hi = span[2 * sp + 1]
        depth = level_of[sp]
        if depth > deepest:
            deepest = depth
        mid = 0.5 * (lo + hi)
        half = 0.5 * (hi - lo)
        r = half * rate[q]
        if lo >= before[q] or (mid >= before[q] and (r <= eps or depth >= DEPTH_LIMIT)):
            continue
        chain_at(mqa, ja[q], mid, Ra, ta)
        chain_at(mqb, jb[q], mid, Rb, tb)
        _relative(Ra, ta, Rb, tb, R, t)
        _frame(R, t, D, W, K, T, f, g, shift)
        scale = fabs(t[0]) + fabs(t[1]) + fabs(t[2]) + reach
        if not _walk_within(R, t, f, g, shift, tr, r, 1e-12 * scale, stack, pair, cp, cq, node_tests + q):
            continue
        if r <= eps or depth >= DEPTH_LIMIT:
            found[q] = 1
            s_out[q] = mid
            pairs[2 * q] = pair[0]
            pairs[2 * q + 1] = pair[1]
            for i in range(3):
                cp[i] = 0.5 * (cp[i] + cq[i])
            _apply(Rb, tb, cp, points + 3 * q)
            break
        # the later half below the earlier one: the earlier half is searched first
        span[2 * sp] = mid
        span[2 * sp + 1] = hi
        level_of[sp] = depth + 1
        span[2 * sp + 2] = lo
        span[2 * sp + 3] = mid
        level_of[sp + 1] = depth + 1
        sp += 2
    levels[q] = deepest


def first_contacts(a, b, D, W, motion_a, joints_a, motion_b, joints_b, rate, double eps, bint parallel_ok=True,
                   before=None):
    """For each query, the first contact of tree ``a`` moving by ``motion_a`` with tree ``b`` moving
    by ``motion_b`` (rows of 30 doubles, ``joints`` (N,) each), ``rate`` (N,) the two motions'
    summed bound (m per unit of s), ``eps`` the bound at which a leaf is reported, m.

    Returns found (N,) int64, s (N,) the leaf's middle (-1 where none), pairs (N, 2) of input
    triangle indices (a, b), points (N, 3) in the world (b's placement applied), node tests (N,)
    and the deepest bisection level (N,). ``parallel_ok`` False: one thread (a batch too small to
    pay for waking the others). ``before`` (N,), optional: a query need not report a contact at or
    after it (the caller has one there already); where the earliest leaf lies before it, the answer
    is the one without it, else none or one at or after it.
    """
    ma = np.ascontiguousarray(motion_a, dtype=np.float64).reshape(-1, 30)
    mb = np.ascontiguousarray(motion_b, dtype=np.float64).reshape(-1, 30)
    ja = np.ascontiguousarray(joints_a, dtype=np.int64).ravel()
    jb = np.ascontiguousarray(joints_b, dtype=np.int64).ravel()
    rt = np.ascontiguousarray(rate, dtype=np.float64).ravel()
    bf = (np.full(ma.shape[0], np.inf) if before is None
          else np.ascontiguousarray(before, dtype=np.float64).ravel())
    Dn = np.ascontiguousarray(D, dtype=np.float64)
    Wn = np.ascontiguousarray(W, dtype=np.float64)
    cdef Py_ssize_t n = ma.shape[0]
    if not (mb.shape[0] == n and ja.shape[0] == n and jb.shape[0] == n and rt.shape[0] == n and bf.shape[0] == n):
        raise ValueError("first_contacts: every query needs both motions, both joint counts and a rate")
    if np.isnan(bf).any():
        raise ValueError("first_contacts: a bound of the contact's fraction is NaN")
    if ((ja < 0) | (ja > 2) | (jb < 0) | (jb > 2)).any():
        raise ValueError("first_contacts: a motion has 0, 1 or 2 joints")
    if not np.isfinite(rt).all() or (rt < 0).any():
        raise ValueError("first_contacts: motion bounds must be finite and >= 0")
    cdef Py_ssize_t K = Dn.shape[0]
    cdef Py_ssize_t T = Wn.shape[0]
    found_arr = np.zeros(n, np.int64)
    s_arr = np.full(n, -1.0)
    pairs_arr = np.full((n, 2), -1, np.int64)
    points_arr = np.full((n, 3), np.nan)
    node_arr = np.zeros(n, np.int64)
    level_arr = np.zeros(n, np.int64)
    if n == 0:
        return found_arr, s_arr, pairs_arr, points_arr, node_arr, level_arr
    cdef Trees tr
    keep = fill_trees(&tr, a, b, K, T)
    cdef double reach = tree_reach(&tr)
    cdef Py_ssize_t depth = int(np.max(keep[6]) + np.max(keep[18]) + 4)
    cdef Py_ssize_t stack_len = 2 * (2 * depth + 2)
    cdef const double* map_ = <const double*>cnp.PyArray_DATA(ma)
    cdef const double* mbp = <const double*>cnp.PyArray_DATA(mb)
    cdef const int64_t* jap = <const int64_t*>cnp.PyArray_DATA(ja)
    cdef const int64_t* jbp = <const int64_t*>cnp.PyArray_DATA(jb)
    cdef const double* rtp = <const double*>cnp.PyArray_DATA(rt)
    cdef const double* bfp = <const double*>cnp.PyArray_DATA(bf)
    cdef const double* Dp = <const double*>cnp.PyArray_DATA(Dn)
    cdef const double* Wp = <const double*>cnp.PyArray_DATA(Wn)
    cdef int64_t* found_p = <int64_t*>cnp.PyArray_DATA(found_arr)
    cdef double* s_p = <double*>cnp.PyArray_DATA(s_arr)
    cdef int64_t* pairs_p = <int64_t*>cnp.PyArray_DATA(pairs_arr)
    cdef double* points_p = <double*>cnp.PyArray_DATA(points_arr)
    cdef int64_t* node_p = <int64_t*>cnp.PyArray_DATA(node_arr)
    cdef int64_t* level_p = <int64_t*>cnp.PyArray_DATA(level_arr)
    cdef double* f = NULL
    cdef double* g = NULL
    cdef double* shift = NULL
    cdef double* span = NULL
    cdef int64_t* level_of = NULL
    cdef int64_t* stack = NULL
    cdef int failed = 0
    cdef int* failed_p = &failed
    cdef Py_ssize_t q
    cdef int threads = tcd_max_threads() if parallel_ok else 1
    with nogil, parallel(num_threads=threads):
        f = <double*>malloc((3 * K + 1) * sizeof(double))
        g = <double*>malloc((3 * K * T + 1) * sizeof(double))
        shift = <double*>malloc((K + 1) * sizeof(double))
        span = <double*>malloc((2 * DEPTH_LIMIT + 8) * sizeof(double))
        level_of = <int64_t*>malloc((DEPTH_LIMIT + 4) * sizeof(int64_t))
        stack = <int64_t*>malloc(stack_len * sizeof(int64_t))
        for q in prange(n, schedule="dynamic", chunksize=4):
            if f == NULL or g == NULL or shift == NULL or span == NULL or level_of == NULL or stack == NULL:
                failed_p[0] = 1
            else:
                _query(q, map_, jap, mbp, jbp, rtp, bfp, eps, Dp, Wp, &tr, reach, f, g, shift, stack, span, level_of,
                       found_p, s_p, pairs_p, points_p, node_p, level_p)
        free(f)
        free(g)
        free(shift)
        free(span)
        free(level_of)
        free(stack)
    if failed:
        raise MemoryError("first_contacts: no memory for a thread's work arrays")
    return found_arr, s_arr, pairs_arr, points_arr, node_arr, level_arr


def chain_placements(motion, joints, s):
    """The placements (R (N, 3, 3), t (N, 3)) of motion rows (N, 30) at fractions s (N,) (the
    compiled chain, for the callers that need the world pose of a reported contact)."""
    m = np.ascontiguousarray(motion, dtype=np.float64).reshape(-1, 30)
    j = np.ascontiguousarray(joints, dtype=np.int64).ravel()
    sv = np.ascontiguousarray(s, dtype=np.float64).ravel()
    cdef Py_ssize_t n = m.shape[0]
    R = np.empty((n, 3, 3))
    t = np.empty((n, 3))
    cdef double[:, ::1] m_ = m
    cdef int64_t[::1] j_ = j
    cdef double[::1] s_ = sv
    cdef double[:, :, ::1] R_ = R
    cdef double[:, ::1] t_ = t
    cdef Py_ssize_t i
    for i in range(n):
        chain_at(&m_[i, 0], j_[i], s_[i], &R_[i, 0, 0], &t_[i, 0])
    return R, t
