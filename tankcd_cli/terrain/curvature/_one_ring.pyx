"""Compiled kernels of ``tankcd_cli.terrain.curvature.one_ring`` (see its docstring): the
per-face and per-vertex passes of the curvature estimators.

``cotan_accumulate`` adds the faces' terms in face order, so its sums are those of the numpy
pass in ``curvature.cotan`` to rounding; float32 vertices keep their edge differences in
float32 (the rest in float64).
"""

import numpy as np

from cython.parallel cimport parallel, prange
from libc.math cimport sqrt
from libc.stdint cimport int64_t, uint8_t
from libc.stdlib cimport free, malloc
from libc.string cimport memcpy

ctypedef fused real_t:
    float
    double


# --- argument checks (the loops below trust them: no bounds checks) ------------------------

def _faces(F):
    """(m, 3) int64, C-contiguous."""
    a = np.asarray(F)
    if a.dtype.kind not in "iu":
        raise TypeError(f"faces must be integers, got {a.dtype}")
    a = np.ascontiguousarray(a, dtype=np.int64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"faces must be (m, 3), got shape {a.shape}")
    return a


cdef int _face_range(const int64_t[:, ::1] F, int64_t lo, int64_t hi) except -1:
    """Raise IndexError unless every index is in [lo, hi)."""
    cdef Py_ssize_t f, k
    cdef int64_t v, bad = 0
    cdef bint found = False
    with nogil:
        for f in range(F.shape[0]):
            for k in range(3):
                v = F[f, k]
                if v < lo or v >= hi:
                    found = True
                    bad = v
                    break
            if found:
                break
    if found:
        raise IndexError(f"face index {bad} out of range for {hi} vertices")
    return 0


def _index_array(x, name):
    a = np.asarray(x)
    if a.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integers, got {a.dtype}")
    return np.ascontiguousarray(a, dtype=np.int64).reshape(-1)


cdef int _check_csr(const int64_t[::1] start, const int64_t[::1] face, Py_ssize_t n, Py_ssize_t m) except -1:
    """start (>= n + 1,) non-decreasing from >= 0 to <= len(face); face entries in [0, m)."""
    cdef Py_ssize_t v, s
    cdef int bad = 0
    if start.shape[0] < n + 1:
        raise ValueError(f"start has {start.shape[0]} entries for {n} vertices (needs n + 1)")
    with nogil:
        if start[0] < 0 or start[n] > face.shape[0]:
            bad = 1
        for v in range(n):
            if start[v + 1] < start[v]:
                bad = 1
        if not bad:
            for s in range(start[0], start[n]):
                if face[s] < 0 or face[s] >= m:
                    bad = 2
    if bad == 1:
        raise ValueError("start is not a CSR offset array into face")
    if bad == 2:
        raise IndexError(f"face lists a face outside the {m} faces")
    return 0


# --- cotan_accumulate --------------------------------------------------------------------

cdef int _cotan(const real_t[:, ::1] V, const int64_t[:, ::1] F, double* K, double* N, double* A) noexcept nogil:
    """The face pass; returns 1 + the first face with a zero double area (its cotangents would
    divide by zero: the caller raises ZeroDivisionError), or 0."""
    cdef Py_ssize_t f
    cdef int a, b, d, c
    cdef int64_t idx[3]
    cdef int64_t i, j, k, p, q, v
    cdef double e[3][3]
    cdef double cot[3]
    cdef double len2[3]
    cdef double nx, ny, nz, dbl, w, area
    cdef bint obtuse
    for f in range(F.shape[0]):
        i = F[f, 0]
        j = F[f, 1]
        k = F[f, 2]
        idx[0] = i
        idx[1] = j
        idx[2] = k
        for c in range(3):
            e[0][c] = V[k, c] - V[j, c]  # opposite corner 0 (in the vertices' precision)
            e[1][c] = V[i, c] - V[k, c]  # opposite corner 1
            e[2][c] = V[j, c] - V[i, c]  # opposite corner 2
        # normal = (X_j - X_i) x (X_k - X_i) = e2 x (-e1)
        nx = -(e[2][1] * e[1][2] - e[2][2] * e[1][1])
        ny = -(e[2][2] * e[1][0] - e[2][0] * e[1][2])
        nz = -(e[2][0] * e[1][1] - e[2][1] * e[1][0])
        if nz < 0:
            nx = -nx
            ny = -ny
            nz = -nz
        dbl = sqrt(nx * nx + ny * ny + nz * nz)
        if dbl == 0.0:
            return <int>f + 1
        for a in range(3):
            b = (a + 1) % 3
            len2[a] = e[a][0] * e[a][0] + e[a][1] * e[a][1] + e[a][2] * e[a][2]
            # cot at corner a = -(e[a+2] . e[a+1]) / |n|
            d = (a + 2) % 3
            cot[a] = -(e[d][0] * e[b][0] + e[d][1] * e[b][1] + e[d][2] * e[b][2]) / dbl
        for a in range(3):
            p = idx[(a + 1) % 3]
            q = idx[(a + 2) % 3]
            for c in range(3):
                w = cot[a] * e[a][c]
                K[3 * p + c] += w
                K[3 * q + c] -= w
            v = idx[a]
            N[3 * v] += nx
            N[3 * v + 1] += ny
            N[3 * v + 2] += nz
        obtuse = cot[0] < 0 or cot[1] < 0 or cot[2] < 0
        area = dbl / 2.0
        for a in range(3):
            v = idx[a]
            if obtuse:
                A[v] += area / 2.0 if cot[a] < 0 else area / 4.0
            else:
                b = (a + 1) % 3
                d = (a + 2) % 3
                A[v] += (len2[d] * cot[d] + len2[b] * cot[b]) / 8.0
    return 0


def cotan_accumulate(V, F):
    """One pass over the faces: K = sum (cot a + cot b)(X_j - X_i), the upward
    area-weighted normal sum and the mixed Voronoi area at each vertex.

    V : (n, 3) float64; F : (m, 3) int64
    Returns K (n, 3), normal sum (n, 3), mixed area (n,).
    """
    Va = np.asarray(V)
    if Va.dtype != np.float32:
        Va = np.ascontiguousarray(Va, dtype=np.float64)
    else:
        Va = np.ascontiguousarray(Va)
    if Va.ndim != 2 or Va.shape[1] != 3:
        raise ValueError(f"vertices must be (n, 3), got shape {Va.shape}")
    Fa = _faces(F)
    cdef Py_ssize_t n = Va.shape[0]
    cdef const int64_t[:, ::1] Fv = Fa
    _face_range(Fv, -n, n)
    if Fa.shape[0] and Fa.min() < 0:
        Fa = np.where(Fa < 0, Fa + n, Fa)  # a negative index counts from the end, as numpy's
        Fv = Fa
    K_arr = np.zeros((n, 3))
    N_arr = np.zeros((n, 3))
    A_arr = np.zeros(n)
    cdef double[:, ::1] K = K_arr
    cdef double[:, ::1] N = N_arr
    cdef double[::1] A = A_arr
    cdef double* Kp = &K[0, 0] if n else NULL
    cdef double* Np = &N[0, 0] if n else NULL
    cdef double* Ap = &A[0] if n else NULL
    cdef const float[:, ::1] V32
    cdef const double[:, ::1] V64
    cdef int bad
    if Va.dtype == np.float32:
        V32 = Va
        with nogil:
            bad = _cotan(V32, Fv, Kp, Np, Ap)
    else:
        V64 = Va
        with nogil:
            bad = _cotan(V64, Fv, Kp, Np, Ap)
    if bad:
        raise ZeroDivisionError("division by zero")
    return K_arr, N_arr, A_arr


# --- vertex-face incidence, boundary flags, rings ----------------------------------------------

cdef void _csr(const int64_t[:, ::1] F, Py_ssize_t n, int64_t* start, int64_t* face, int64_t* fill) noexcept nogil:
    """Fill start (n + 1, zeroed) and face (start[n]); fill: scratch (n,)."""
    cdef Py_ssize_t f, v
    cdef int a
    cdef int64_t u
    for f in range(F.shape[0]):
        for a in range(3):
            start[F[f, a] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    if n:
        memcpy(fill, start, n * sizeof(int64_t))
    for f in range(F.shape[0]):
        for a in range(3):
            u = F[f, a]
            face[fill[u]] = f
            fill[u] += 1


cdef object _csr_arrays(const int64_t[:, ::1] F, Py_ssize_t n):
    start_arr = np.zeros(n + 1, np.int64)
    cdef int64_t[::1] start = start_arr
    face_arr = np.empty(3 * F.shape[0], np.int64)  # every incidence: start[n] == 3 m
    cdef int64_t[::1] face = face_arr
    cdef int64_t* fill = <int64_t*>malloc((n if n else 1) * sizeof(int64_t))
    if fill == NULL:
        raise MemoryError()
    cdef int64_t* fp = &face[0] if F.shape[0] else NULL
    with nogil:
        _csr(F, n, &start[0], fp, fill)
    free(fill)
    return start_arr, face_arr


def vertex_face_csr(F, n):
    """Faces around each vertex: vertex v has faces face[start[v]:start[v + 1]]."""
    cdef Py_ssize_t nv = n
    if nv < 0:
        raise ValueError("negative dimensions not allowed")
    Fa = _faces(F)
    _face_range(Fa, 0, nv)
    return _csr_arrays(Fa, nv)


cdef inline void _vertex_flags(const int64_t* F, int64_t v, const int64_t* start, const int64_t* face,
                               int64_t* other, uint8_t* boundary, uint8_t* nonmanifold) noexcept nogil:
    cdef int64_t s, f, u, t, p, run, q
    cdef int a
    cdef int64_t s0 = start[v]
    cdef int64_t s1 = start[v + 1]
    if s1 == s0:
        boundary[v] = 1
        return
    t = 0
    for s in range(s0, s1):
        f = face[s]
        for a in range(3):
            u = F[3 * f + a]
            if u != v:
                # insertion sort: the ring holds a dozen entries or so
                p = t
                while p > 0:
                    q = other[p - 1]
                    if q <= u:
                        break
                    other[p] = q
                    p -= 1
                other[p] = u
                t += 1
    run = 1
    for s in range(1, t + 1):
        if s < t and other[s] == other[s - 1]:
            run += 1
        else:
            if run == 1:
                boundary[v] = 1
            elif run > 2:
                nonmanifold[v] = 1
            run = 1


cdef int _flags(const int64_t[:, ::1] F, Py_ssize_t n, const int64_t[::1] start, const int64_t[::1] face,
                uint8_t* boundary, uint8_t* nonmanifold) noexcept nogil:
    """Per-vertex flags, vertices in parallel (each thread its own ring buffer); -1: out of memory."""
    cdef Py_ssize_t v, widest = 0
    cdef int64_t* other = NULL
    cdef int failed = 0
    cdef int* failed_p = &failed  # written through the pointer: shared, not a private of the loop
    cdef const int64_t* Fp = &F[0, 0] if F.shape[0] else NULL
    cdef const int64_t* sp = &start[0]
    cdef const int64_t* fp = &face[0] if face.shape[0] else NULL
    for v in range(n):
        if sp[v + 1] - sp[v] > widest:
            widest = sp[v + 1] - sp[v]
    with parallel():
        # 3 per face bounds the ring even when face and F disagree (2 when they agree)
        other = <int64_t*>malloc((3 * widest + 1) * sizeof(int64_t))
        for v in prange(n, schedule="dynamic", chunksize=4096):
            if other == NULL:
                failed_p[0] = 1
            else:
                _vertex_flags(Fp, v, sp, fp, other, boundary, nonmanifold)
        free(other)
    return -1 if failed else 0


cdef object _flag_arrays(const int64_t[:, ::1] F, Py_ssize_t n, const int64_t[::1] start, const int64_t[::1] face):
    boundary_arr = np.zeros(n, np.bool_)
    nonmanifold_arr = np.zeros(n, np.bool_)
    cdef uint8_t[::1] b = boundary_arr.view(np.uint8)
    cdef uint8_t[::1] nm = nonmanifold_arr.view(np.uint8)
    cdef int st = 0
    if n:
        with nogil:
            st = _flags(F, n, start, face, &b[0], &nm[0])
    if st < 0:
        raise MemoryError()
    return boundary_arr, nonmanifold_arr


def boundary_flags(F, n, start, face):
    """Per vertex: on a boundary edge (a ring neighbour seen once) or a
    non-manifold edge (seen more than twice). Isolated vertices count as boundary."""
    cdef Py_ssize_t nv = n
    if nv < 0:
        raise ValueError("negative dimensions not allowed")
    Fa = _faces(F)
    st = _index_array(start, "start")
    fc = _index_array(face, "face")
    _check_csr(st, fc, nv, Fa.shape[0])
    return _flag_arrays(Fa, nv, st, fc)


cdef Py_ssize_t _grow(const int64_t[:, ::1] F, const int64_t[::1] start, const int64_t[::1] face,
                      uint8_t* mark, Py_ssize_t n, Py_ssize_t rings, int64_t* cur, int64_t* nxt) noexcept nogil:
    """Breadth-first growth from the marked vertices, ``rings`` frontiers deep. The frontiers live
    in ``cur`` and ``nxt``: a vertex enters a frontier only when first marked, so n entries hold any."""
    cdef Py_ssize_t it, i, nc = 0, nn
    cdef int64_t v, s, f, u
    cdef int a
    cdef int64_t* tmp
    for i in range(n):
        if mark[i]:
            cur[nc] = i
            nc += 1
    for it in range(rings):
        nn = 0
        for i in range(nc):
            v = cur[i]
            for s in range(start[v], start[v + 1]):
                f = face[s]
                for a in range(3):
                    u = F[f, a]
                    if not mark[u]:
                        mark[u] = 1
                        nxt[nn] = u
                        nn += 1
        tmp = cur
        cur = nxt
        nxt = tmp
        nc = nn
        if nc == 0:
            break
    return 0


cdef object _grow_array(const int64_t[:, ::1] F, const int64_t[::1] start, const int64_t[::1] face, seed,
                        Py_ssize_t rings):
    mark_arr = np.array(seed, dtype=np.bool_, copy=True).reshape(-1)
    cdef Py_ssize_t n = mark_arr.shape[0]
    cdef uint8_t[::1] mark = mark_arr.view(np.uint8)
    if n == 0 or rings <= 0:
        return mark_arr
    cdef int64_t* cur = <int64_t*>malloc(n * sizeof(int64_t))
    cdef int64_t* nxt = <int64_t*>malloc(n * sizeof(int64_t))
    if cur == NULL or nxt == NULL:
        free(cur)
        free(nxt)
        raise MemoryError()
    with nogil:
        _grow(F, start, face, &mark[0], n, rings, cur, nxt)
    free(cur)
    free(nxt)
    return mark_arr


def grow_rings(F, start, face, seed, rings):
    """Vertices within ``rings`` edge hops of a seed vertex (mask)."""
    Fa = _faces(F)
    st = _index_array(start, "start")
    fc = _index_array(face, "face")
    sd = np.asarray(seed)
    cdef Py_ssize_t n = sd.size
    _check_csr(st, fc, n, Fa.shape[0])
    _face_range(Fa, 0, n)
    mark = _grow_array(Fa, st, fc, sd, rings)
    if sd.dtype == np.bool_:
        return mark
    out = sd.reshape(-1).copy()  # the mask in the seed's dtype: the seed with the grown vertices set
    out[mark & ~sd.reshape(-1).astype(np.bool_)] = True
    return out


def open_vertex_flags(F, n, rings):
    """Boundary and non-manifold flags, and the vertices within ``rings`` hops of either."""
    cdef Py_ssize_t nv = n
    if nv < 0:
        raise ValueError("negative dimensions not allowed")
    Fa = _faces(F)
    _face_range(Fa, 0, nv)
    start, face = _csr_arrays(Fa, nv)
    boundary, nonmanifold = _flag_arrays(Fa, nv, start, face)
    near = _grow_array(Fa, start, face, boundary | nonmanifold, rings)
    return boundary, nonmanifold, near
