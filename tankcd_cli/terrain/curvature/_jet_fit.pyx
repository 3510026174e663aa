"""Compiled kernels of ``tankcd_cli.terrain.curvature.jet_fit`` (see its docstring): the ``jet`` mean
curvature, neighbour search and per-vertex quartic fit, vertices in parallel.

The numpy twins in ``curvature.jet`` (``nearest_neighbours`` with cKDTree, ``jet_fit_numpy``) are the
oracle. The neighbour rule is theirs to the bit: squared distances summed x, y, z in that order on
the pool's centred coordinates (cKDTree's arithmetic), the ``extra`` nearest (ties by index),
keys ``rint(dist / dist_extra * 1e9)``, ties by vertex index, the vertex itself dropped, the first
``k`` kept. The search: a median-split kd-tree; queries in tree order, each bounded by the
previous query's ``extra`` nearest, candidates gathered unsorted and chosen by a histogram of
their distances (no sorting). The fit follows ``jet_fit_numpy`` formula by formula; its 3 x 3
eigenproblem is solved in closed form with Newton polish (cyclic Jacobi where eigenvalues are
close), the normal equations come from the distinct moments and are solved by Cholesky (LU with
partial pivoting should a pivot fail), so H agrees with the oracle to rounding amplified by the
system's condition: about 1e-10 relative on ordinary meshes.

The k-d tree and its search are in ``_kdtree.pxd``, the eigenvector and the solvers in
``_small_linalg.pxd``: inline functions, compiled into this module (setup.py rebuilds it when
either changes)."""

import numpy as np

from cython.parallel cimport parallel, prange
from libc.math cimport INFINITY, fabs, pow, sqrt
from libc.stdint cimport int64_t
from libc.stdlib cimport free, malloc

from tankcd_cli.terrain.curvature._kdtree cimport (
    STACK, Tree, build_node, comes_before, knn_candidates, tree_alloc, tree_free,
)
from tankcd_cli.terrain.curvature._small_linalg cimport cholesky_solve, eig_smallest, lu_solve

cdef enum:
    NMON = 14         # monomials of a quartic through the origin
    HBINS = 64        # histogram bins of the candidates' squared distances
    QCHUNK = 256      # queries a thread takes at a time (tree order: neighbouring queries)


# --- the neighbour rule (the k-d tree: _kdtree.pxd) -----------------------------------------------


cdef inline double _rint(double x) noexcept nogil:
    """Round half to even (np.round), for x >= 0 or NaN: adding 2^52 leaves no fraction bits."""
    if x < 4503599627370496.0:
        return (x + 4503599627370496.0) - 4503599627370496.0
    return x


cdef int64_t _nth_in_bin(const double* bd, const int64_t* bi, int64_t n, const int* bin, int b, int64_t rank,
                         double limd, int64_t limi, int64_t* tmp) noexcept nogil:
    """Position of the rank-th (from 0) candidate by (distance, index) among those in bin b that come
    no later than (limd, limi)."""
    cdef int64_t j, c = 0, pos, x
    for j in range(n):
        if bin[j] == b and not comes_before(limd, limi, bd[j], bi[j]):
            x = j
            pos = c
            while pos > 0 and comes_before(bd[x], bi[x], bd[tmp[pos - 1]], bi[tmp[pos - 1]]):
                tmp[pos] = tmp[pos - 1]
                pos -= 1
            tmp[pos] = x
            c += 1
    return tmp[rank]


cdef int64_t _choose(const double* bd, const int64_t* bi, int64_t n, double r2, int64_t K, int64_t k,
                     int64_t self_id, int64_t* out, int* bin, int64_t* tmp, int64_t* kset,
                     double* scale_out) noexcept nogil:
    """The k neighbours (in no order) among n candidates (distinct points, every point nearer than
    the K-th among them): of the K nearest by (distance, index), ranked by (key, index) with
    key = rint(dist / dist_K * 1e9), less self_id, the first k. Returns how many (k, or fewer).

    Histogram of the squared distances over [0, r2] finds the K-th and the (k + 1)-th nearest
    without sorting; keys are computed only within 2e-9 dist_K of the (k + 1)-th, where they can tie."""
    cdef int hist[HBINS]
    cdef int64_t j, cum, pos, got = 0, want, nt = 0
    cdef int b, bK, bT
    cdef double f, d2K, d2T, scale, dT, kT, lo2, hi2, kj
    cdef int64_t iK, x, nk = 0
    cdef int member
    kset[K] = 0
    scale_out[0] = 1e-300
    if n == 0:
        return 0
    if K > n:
        K = n
    if k + 1 > K:
        k = K - 1
    if not (r2 < INFINITY):
        r2 = 0.0
        for j in range(n):
            if bd[j] > r2:
                r2 = bd[j]
    f = HBINS / r2 if r2 > 0.0 else 0.0
    for b in range(HBINS):
        hist[b] = 0
    for j in range(n):
        b = <int>(bd[j] * f)
        if b >= HBINS:
            b = HBINS - 1
        bin[j] = b
        hist[b] += 1
    # the K-th nearest: (d2K, iK)
    cum = 0
    bK = 0
    while cum + hist[bK] < K:
        cum += hist[bK]
        bK += 1
    x = _nth_in_bin(bd, bi, n, bin, bK, K - 1 - cum, INFINITY, 0x7FFFFFFFFFFFFFFF, tmp)
    d2K = bd[x]
    iK = bi[x]
    scale = sqrt(d2K)
    if scale < 1e-300:  # np.maximum(dist, 1e-300)
        scale = 1e-300
    scale_out[0] = scale
    for j in range(n):
        kset[nk] = bi[j]
        nk += <int64_t>((bd[j] < d2K) | ((bd[j] == d2K) & (bi[j] <= iK)))
    kset[K] = nk
    if k <= 0:
        return 0
    # the (k + 1)-th nearest of those K: its key bounds the k + 1 taken
    cum = 0
    bT = 0
    while cum + hist[bT] < k + 1:
        cum += hist[bT]
        bT += 1
    x = _nth_in_bin(bd, bi, n, bin, bT, k - cum, d2K, iK, tmp)
    d2T = bd[x]
    dT = sqrt(d2T)
    kT = _rint(dT / scale * 1e9)
    lo2 = dT - 2e-9 * scale
    lo2 = lo2 * lo2 if lo2 > 0.0 else -1.0
    hi2 = dT + 2e-9 * scale
    hi2 = hi2 * hi2
    for j in range(n):
        # among the K nearest, clearly before the (k + 1)-th and not the vertex itself: taken
        member = (bd[j] < d2K) | ((bd[j] == d2K) & (bi[j] <= iK))
        out[got] = bi[j]
        got += <int64_t>(member & (bd[j] < lo2) & (bi[j] != self_id))
        if member & (bd[j] >= lo2) & (bd[j] <= hi2):  # near the (k + 1)-th: by key (rare)
            kj = _rint(sqrt(bd[j]) / scale * 1e9)
            if kj > kT:
                continue
            if kj == kT:
                if bi[j] != self_id:  # a tie: by index below
                    pos = nt
                    while pos > 0 and tmp[pos - 1] > bi[j]:
                        tmp[pos] = tmp[pos - 1]
                        pos -= 1
                    tmp[pos] = bi[j]
                    nt += 1
            elif bi[j] != self_id:
                out[got] = bi[j]
                got += 1
    want = k - got
    if want > nt:
        want = nt
    for j in range(want):
        out[got] = tmp[j]
        got += 1
    return got


cdef void _order_keys(const double* P, const double* q, double scale, int64_t* out, int64_t got,
                      double* key) noexcept nogil:
    """Sort out[:got] by (key, index), key = rint(dist / scale * 1e9) with cKDTree's distances."""
    cdef int64_t a, pos, ia
    cdef double dx, dy, dz, d2, ka
    for a in range(got):
        ia = out[a]
        dx = P[3 * ia] - q[0]
        dy = P[3 * ia + 1] - q[1]
        dz = P[3 * ia + 2] - q[2]
        d2 = dx * dx + dy * dy
        d2 = d2 + dz * dz
        ka = _rint(sqrt(d2) / scale * 1e9)
        pos = a
        while pos > 0 and (key[pos - 1] > ka or (key[pos - 1] == ka and out[pos - 1] > ia)):
            key[pos] = key[pos - 1]
            out[pos] = out[pos - 1]
            pos -= 1
        key[pos] = ka
        out[pos] = ia


# --- the fit (its eigenvector and solves: _small_linalg.pxd) --------------------------------------


cdef double _fit(const double* V, int64_t ci, const int64_t* nb, int64_t k, const double* hint,
                 int degree, double* d, double* M) noexcept nogil:
    """H at vertex ci from its k neighbours nb: ``jet_fit_numpy`` for one vertex.
    Scratch: d (3 k), M (NMON * NMON). The normal equations come from the 42 distinct moments
    sum u^p v^q (2 <= p + q <= 8) rather than 105 products of monomials; Cholesky solves them
    (LU with partial pivoting should a pivot fail)."""
    cdef int64_t j
    cdef int a, b, c, r, count, piv, deg, top, e
    cdef double cx = V[3 * ci], cy = V[3 * ci + 1], cz = V[3 * ci + 2]
    cdef double sx = 0.0, sy = 0.0, sz = 0.0, sxx = 0.0, sxy = 0.0, sxz = 0.0, syy = 0.0, syz = 0.0, szz = 0.0
    cdef double x, y, z, cnt, mx, my, mz, side, ss, s, u, v, w, trace, ridge, big, f, tmp
    cdef double C[9]
    cdef double n[3]
    cdef double h[3]
    cdef double t1[3]
    cdef double t2[3]
    cdef double B[NMON]
    cdef double rhs[NMON]
    cdef double up[9]
    cdef double vr[9]
    cdef double S[45]
    cdef double D[NMON]
    cdef double inv
    cdef double fu, fv, fuu, fuv, fvv, g
    cdef bint ok
    if k <= 0:
        return 0.0
    for j in range(k):
        x = V[3 * nb[j]] - cx
        y = V[3 * nb[j] + 1] - cy
        z = V[3 * nb[j] + 2] - cz
        d[3 * j] = x
        d[3 * j + 1] = y
        d[3 * j + 2] = z
        sx += x
        sy += y
        sz += z
        sxx += x * x
        sxy += x * y
        sxz += x * z
        syy += y * y
        syz += y * z
        szz += z * z
    # _fit_normal: covariance with the vertex at the origin
    cnt = <double>k + 1.0
    mx = sx / cnt
    my = sy / cnt
    mz = sz / cnt
    C[0] = sxx / cnt - mx * mx
    C[1] = sxy / cnt - mx * my
    C[2] = sxz / cnt - mx * mz
    C[4] = syy / cnt - my * my
    C[5] = syz / cnt - my * mz
    C[8] = szz / cnt - mz * mz
    C[3] = C[1]
    C[6] = C[2]
    C[7] = C[5]
    eig_smallest(C, n)
    if fabs(n[2]) > 1e-6:
        side = n[2]
    else:
        side = n[0] * hint[0] + n[1] * hint[1] + n[2] * hint[2]
    if side < 0:
        n[0] = -n[0]
        n[1] = -n[1]
        n[2] = -n[2]
    # tangent frame: t1 = n x helper, t2 = n x t1
    if fabs(n[0]) < 0.9:
        h[0] = 1.0
        h[1] = 0.0
    else:
        h[0] = 0.0
        h[1] = 1.0
    h[2] = 0.0
    t1[0] = n[1] * h[2] - n[2] * h[1]
    t1[1] = n[2] * h[0] - n[0] * h[2]
    t1[2] = n[0] * h[1] - n[1] * h[0]
    tmp = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2])
    t1[0] = t1[0] / tmp
    t1[1] = t1[1] / tmp
    t1[2] = t1[2] / tmp
    t2[0] = n[1] * t1[2] - n[2] * t1[1]
    t2[1] = n[2] * t1[0] - n[0] * t1[2]
    t2[2] = n[0] * t1[1] - n[1] * t1[0]
    s = sqrt((sxx + syy + szz) / <double>k)
    if not (s > 0):
        s = 1.0
    deg = 4 if degree >= 4 else 3
    count = 14 if deg == 4 else 9
    top = 2 * deg  # moments of degree 2 .. top, degree e stored from _MOFF[e]: sum u^p v^(e - p)
    for a in range(_MOFF[top + 1]):
        S[a] = 0.0
    for a in range(NMON):
        rhs[a] = 0.0
    up[0] = 1.0
    vr[8] = 1.0
    inv = 1.0 / s
    for j in range(k):
        x = d[3 * j]
        y = d[3 * j + 1]
        z = d[3 * j + 2]
        u = (x * t1[0] + y * t1[1] + z * t1[2]) * inv
        v = (x * t2[0] + y * t2[1] + z * t2[2]) * inv
        w = (x * n[0] + y * n[1] + z * n[2]) * inv
        # the monomials as jet_fit_numpy forms them
        B[0] = u
        B[1] = v
        B[2] = u * u
        B[3] = u * v
        B[4] = v * v
        B[5] = B[2] * u
        B[6] = B[2] * v
        B[7] = u * B[4]
        B[8] = B[4] * v
        B[9] = B[2] * B[2]
        B[10] = B[2] * B[3]
        B[11] = B[2] * B[4]
        B[12] = B[3] * B[4]
        B[13] = B[4] * B[4]
        for a in range(NMON):
            rhs[a] += B[a] * w
        # powers: up[p] = u^p, vr[8 - q] = v^q (reversed: sum u^p v^(e-p) runs forward in both)
        up[1] = u
        up[2] = B[2]
        up[3] = B[5]
        up[4] = B[9]
        vr[7] = v
        vr[6] = B[4]
        vr[5] = B[8]
        vr[4] = B[13]
        if deg == 4:  # constant bounds: unrolled and vectorized
            up[5] = up[4] * u
            up[6] = up[5] * u
            up[7] = up[6] * u
            up[8] = up[7] * u
            vr[3] = vr[4] * v
            vr[2] = vr[3] * v
            vr[1] = vr[2] * v
            vr[0] = vr[1] * v
            for e in range(2, 9):
                for a in range(e + 1):
                    S[_MOFF_C[e] + a] += up[a] * vr[8 - e + a]
        else:
            up[5] = up[4] * u
            up[6] = up[5] * u
            vr[3] = vr[4] * v
            vr[2] = vr[3] * v
            for e in range(2, 7):
                for a in range(e + 1):
                    S[_MOFF_C[e] + a] += up[a] * vr[8 - e + a]
    for a in range(count):
        for b in range(a, count):
            e = _MDEG[a] + _MDEG[b]
            f = S[_MOFF[e] + _MPU[a] + _MPU[b]]
            M[a * count + b] = f
            M[b * count + a] = f
    trace = 0.0
    for a in range(count):
        trace += M[a * count + a]
    ridge = 1e-10 * trace / count + 1e-300
    for a in range(count):
        M[a * count + a] += ridge
        D[a] = M[a * count + a]
    if count == NMON:  # constant sizes: the loops unroll
        ok = cholesky_solve(M, rhs, D, NMON)
    else:
        ok = cholesky_solve(M, rhs, D, 9)
    if not ok:
        for a in range(count):
            M[a * count + a] = D[a]
        if not lu_solve(M, rhs, count):
            return 0.0  # singular (numpy would raise): no curvature to report
    fu = rhs[0]
    fv = rhs[1]
    fuu = 2 * rhs[2] / s
    fuv = rhs[3] / s
    fvv = 2 * rhs[4] / s
    g = 1.0 + fu * fu + fv * fv
    return -((1 + fv * fv) * fuu - 2 * fu * fv * fuv + (1 + fu * fu) * fvv) / (2.0 * pow(g, 1.5))


# monomial a of the jet is u^(_MPU[a]) v^(_MDEG[a] - _MPU[a]); moments of degree e start at _MOFF[e]
cdef extern from *:
    """
    static const int _MOFF_C[10] = {0, 0, 0, 3, 7, 12, 18, 25, 33, 42};
    """
    const int _MOFF_C[10]

cdef int _MDEG[NMON]
cdef int _MPU[NMON]
cdef int _MOFF[10]
_MDEG[:] = [1, 1, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 4]
_MPU[:] = [1, 0, 2, 1, 0, 3, 2, 1, 0, 4, 3, 2, 1, 0]
_MOFF[:] = [0, 0, 0, 3, 7, 12, 18, 25, 33, 42]


# --- Python entry points --------------------------------------------------------------------------

def _vertices(V, name="vertices"):
    a = np.ascontiguousarray(V, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must be (n, 3), got shape {a.shape}")
    return a


def _indices(x, n, name):
    a = np.asarray(x)
    if a.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integers, got {a.dtype}")
    a = np.ascontiguousarray(a, dtype=np.int64)
    if a.size and (a.min() < 0 or a.max() >= n):
        raise IndexError(f"{name} holds an index outside the {n} vertices")
    return a


def jet_fit(V, normal, centre, nbr, int degree=4):
    """H (c,) at the vertices ``centre`` (c,) from their neighbours ``nbr`` (c, k): the compiled
    ``curvature.jet.jet_fit_numpy``. V, normal: (n, 3) float64 (normal: the orientation hint)."""
    Va = _vertices(V)
    Na = _vertices(normal, "normal")
    cdef Py_ssize_t n = Va.shape[0]
    if Na.shape[0] != n:
        raise ValueError("normal must have one row per vertex")
    ca = _indices(centre, n, "centre").reshape(-1)
    na = _indices(nbr, n, "nbr")
    if na.ndim != 2 or na.shape[0] != ca.shape[0]:
        raise ValueError(f"nbr must be (len(centre), k), got shape {na.shape}")
    if degree not in (3, 4):
        raise ValueError("degree must be 3 or 4")
    cdef Py_ssize_t c = ca.shape[0], k = na.shape[1], i
    H_arr = np.zeros(c)
    if c == 0:
        return H_arr
    cdef double[::1] H = H_arr
    cdef const double[:, ::1] Vv = Va
    cdef const double[:, ::1] Nv = Na
    cdef const int64_t[::1] cv = ca
    cdef const int64_t[:, ::1] nv = np.ascontiguousarray(na) if k else np.zeros((c, 1), np.int64)
    cdef const double* Vp = &Vv[0, 0]
    cdef const double* Np = &Nv[0, 0]
    cdef double* d = NULL
    cdef double* M = NULL
    cdef int failed = 0
    cdef int* failed_p = &failed
    cdef int deg = degree
    with nogil, parallel():
        d = <double*>malloc((3 * k + 3) * sizeof(double))
        M = <double*>malloc(NMON * NMON * sizeof(double))
        for i in prange(c, schedule="dynamic", chunksize=QCHUNK):
            if d == NULL or M == NULL:
                failed_p[0] = 1
            else:
                H[i] = _fit(Vp, cv[i], &nv[i, 0], k, Np + 3 * cv[i], deg, d, M)
        free(d)
        free(M)
    if failed:
        raise MemoryError()
    return H_arr


cdef int _make_tree(Tree* t, const double[:, ::1] P) noexcept nogil:
    cdef int64_t m = P.shape[0], p, next_node = 1
    cdef int c
    if tree_alloc(t, m) < 0:
        return -1
    for p in range(m):
        for c in range(3):
            t.X[3 * p + c] = P[p, c]
        t.ID[p] = p
    build_node(t, 0, 0, m, &next_node)
    return 0


cdef object _query_order(Tree* t, const int64_t[::1] query):
    """Positions into ``query`` sorted by the tree order of their points (neighbouring queries
    share neighbours: the cache holds them)."""
    cdef Py_ssize_t m = t.m, q = query.shape[0], i, j = 0
    slot_arr = np.full(m, -1, np.int64)
    cdef int64_t[::1] slot = slot_arr
    order_arr = np.empty(q, np.int64)
    cdef int64_t[::1] order = order_arr
    with nogil:
        for i in range(q):
            slot[query[i]] = i
        for i in range(m):
            if slot[t.ID[i]] >= 0:
                order[j] = slot[t.ID[i]]
                j += 1
    if j != q:  # repeated queries: plain order
        return np.arange(q, dtype=np.int64)
    return order_arr


def _check_pool(P, query, k, extra):
    Pa = _vertices(P, "points")
    m = Pa.shape[0]
    qa = _indices(query, m, "query").reshape(-1)
    if not (0 <= k < extra <= m):
        raise ValueError(f"need 0 <= k < extra <= {m} points, got k={k}, extra={extra}")
    if not np.isfinite(Pa).all():
        raise ValueError("points must be finite")
    return Pa, qa


cdef int _run(const Tree* t, const double* P, const int64_t* query, const int64_t* order, int64_t q,
              int64_t k, int64_t K, int64_t* out, const double* V, const double* N, const int64_t* pool,
              int degree, double* H) noexcept nogil:
    """Each query in parallel: its k neighbours (local indices into out, in order, when out is not
    NULL) and, when H is not NULL, the fit over them (global indices pool[local] into V and N)."""
    cdef int64_t i, qi, got, j, cnt, cap = 4 * K + 8
    cdef double r2, dx, dy, dz, d2, scale
    cdef const double* qp
    cdef double* bd = NULL
    cdef int64_t* bi = NULL
    cdef int* bins = NULL
    cdef int64_t* tmp = NULL
    cdef double* cd = NULL
    cdef double* key = NULL
    cdef int64_t* seed = NULL
    cdef int64_t* st_node = NULL
    cdef double* st_dist = NULL
    cdef int64_t* nb = NULL
    cdef double* d = NULL
    cdef double* M = NULL
    cdef int failed = 0
    cdef int* failed_p = &failed
    with parallel():
        bd = <double*>malloc(cap * sizeof(double))
        bi = <int64_t*>malloc(cap * sizeof(int64_t))
        bins = <int*>malloc(cap * sizeof(int))
        tmp = <int64_t*>malloc(cap * sizeof(int64_t))
        cd = <double*>malloc(cap * sizeof(double))
        key = <double*>malloc((k + 1) * sizeof(double))
        seed = <int64_t*>malloc((K + 1) * sizeof(int64_t))  # seed[K]: how many
        st_node = <int64_t*>malloc(STACK * sizeof(int64_t))
        st_dist = <double*>malloc(STACK * sizeof(double))
        nb = <int64_t*>malloc((k + 1) * sizeof(int64_t))
        d = <double*>malloc((3 * k + 3) * sizeof(double))
        M = <double*>malloc(NMON * NMON * sizeof(double))
        if seed != NULL:
            seed[K] = 0
        for i in prange(q, schedule="dynamic", chunksize=QCHUNK):
            if (bd == NULL or bi == NULL or bins == NULL or tmp == NULL or cd == NULL or key == NULL or seed == NULL
                    or st_node == NULL or st_dist == NULL or nb == NULL or d == NULL or M == NULL):
                failed_p[0] = 1
            else:
                qi = order[i]
                qp = P + 3 * query[qi]
                # the previous query's K nearest (a neighbour in tree order) bound the search radius
                r2 = INFINITY
                if seed[K] == K:
                    r2 = 0.0
                    for j in range(K):
                        dx = P[3 * seed[j]] - qp[0]
                        dy = P[3 * seed[j] + 1] - qp[1]
                        dz = P[3 * seed[j] + 2] - qp[2]
                        d2 = dx * dx + dy * dy
                        d2 = d2 + dz * dz
                        r2 = d2 if d2 > r2 else r2
                cnt = knn_candidates(t, qp, K, r2, bd, bi, cap, st_node, st_dist, &r2, cd, tmp)
                scale = 1e-300  # assigned here so that prange makes it private (_choose sets it by pointer)
                got = _choose(bd, bi, cnt, r2, K, k, query[qi], nb, bins, tmp, seed, &scale)
                # in rank order: the fit's sums then run in the same order whatever the pool
                _order_keys(P, qp, scale, nb, got, key)
                if out != NULL:
                    for j in range(got):
                        out[qi * k + j] = nb[j]
                if H != NULL:
                    for j in range(got):
                        nb[j] = pool[nb[j]]
                    H[qi] = _fit(V, pool[query[qi]], nb, got, N + 3 * pool[query[qi]], degree, d, M)
        free(bd)
        free(bi)
        free(bins)
        free(tmp)
        free(cd)
        free(key)
        free(seed)
        free(st_node)
        free(st_dist)
        free(nb)
        free(d)
        free(M)
    return -1 if failed else 0


cdef object _search(P, query, Py_ssize_t k, Py_ssize_t extra, out_arr, V, N, pool, int degree, H_arr):
    Pa, qa = _check_pool(P, query, k, extra)
    cdef Py_ssize_t q = qa.shape[0]
    if q == 0:
        return
    cdef const double[:, ::1] Pv = Pa
    cdef const int64_t[::1] qv = qa
    cdef int64_t[:, ::1] outv
    cdef const double[:, ::1] Vv
    cdef const double[:, ::1] Nv
    cdef const int64_t[::1] poolv
    cdef double[::1] Hv
    cdef int64_t* outp = NULL
    cdef const double* Vp = NULL
    cdef const double* Np = NULL
    cdef const int64_t* poolp = NULL
    cdef double* Hp = NULL
    if out_arr is not None:
        outv = out_arr
        outp = &outv[0, 0] if k else NULL
    if H_arr is not None:
        Vv = V
        Nv = N
        poolv = pool
        Hv = H_arr
        Vp = &Vv[0, 0]
        Np = &Nv[0, 0]
        poolp = &poolv[0]
        Hp = &Hv[0]
    cdef Tree t
    cdef int st
    with nogil:
        st = _make_tree(&t, Pv)
    if st < 0:
        tree_free(&t)
        raise MemoryError()
    try:
        order_arr = _query_order(&t, qv)
        st = _run_checked(&t, Pv, qv, order_arr, k, extra, outp, Vp, Np, poolp, degree, Hp)
    finally:
        tree_free(&t)
    if st < 0:
        raise MemoryError()


cdef int _run_checked(const Tree* t, const double[:, ::1] Pv, const int64_t[::1] qv, const int64_t[::1] order,
                      Py_ssize_t k, Py_ssize_t extra, int64_t* outp, const double* Vp, const double* Np,
                      const int64_t* poolp, int degree, double* Hp):
    cdef int st
    with nogil:
        st = _run(t, &Pv[0, 0], &qv[0], &order[0], qv.shape[0], k, extra, outp, Vp, Np, poolp, degree, Hp)
    return st


def neighbours(P, query, Py_ssize_t k, Py_ssize_t extra):
    """Local indices (q, k) of the k nearest other points of each query point, by the rule of
    ``curvature.nearest_neighbours``: the ``extra`` nearest, distance keys rint(d / d_extra * 1e9),
    ties by index, the point itself dropped (-1 pads a row when fewer remain).

    P : (m, 3) float64, the pool's points, centred (the distances are cKDTree's)
    query : (q,) indices into P
    """
    out_arr = np.full((len(np.asarray(query).reshape(-1)), k), -1, np.int64)
    _search(P, query, k, extra, out_arr, None, None, None, 4, None)
    return out_arr


def jet_curvature(V, normal, P, pool, query, Py_ssize_t k, Py_ssize_t extra, int degree=4):
    """H (q,) at the pool points ``query`` from the fit over their ``neighbours`` (P, query, k,
    extra), found and fitted in one pass without storing them.

    V, normal : (n, 3) float64, all vertices and the orientation hints
    P : (m, 3) float64, V[pool] centred; pool : (m,) vertex indices; query : (q,) indices into P
    """
    Va = _vertices(V)
    Na = _vertices(normal, "normal")
    n = Va.shape[0]
    if Na.shape[0] != n:
        raise ValueError("normal must have one row per vertex")
    pa = _indices(pool, n, "pool").reshape(-1)
    if pa.shape[0] != np.asarray(P).shape[0]:
        raise ValueError("pool must have one entry per point")
    if degree not in (3, 4):
        raise ValueError("degree must be 3 or 4")
    H_arr = np.zeros(len(np.asarray(query).reshape(-1)))
    _search(P, query, k, extra, None, Va, Na, pa, degree, H_arr)
    return H_arr
