"""Compiled kernels of ``tankcd_cli.geometry.cylinders`` (see its docstring): GJK on support mappings.

The (at most 3 x 3) Gram system of a simplex face, its determinant test and its solution, is
done by ``_lu``/``_lu_solve``: the operations of LAPACK's ``getf2``/``getrs`` as OpenBLAS's
Haswell/Zen kernels run them, fused multiply-adds included, and the determinant as
``np.linalg.det`` forms it (``sign * exp(sum log |u_kk|)``). Written out here, they give the
same bits on every CPU (a LAPACK call would not: OpenBLAS picks its kernels per CPU).
"""

import numpy as np

from cython.parallel cimport prange
from libc.math cimport exp, fabs, fma, isfinite, log, sqrt, INFINITY
from libc.stdlib cimport free, malloc

TOL = 1e-9
MAX_ITER = 128

cdef enum:
    _MAX_ITER = 128

cdef double _DBL_MIN = 2.2250738585072014e-308  # OpenBLAS getf2: below it, divide instead of scaling by 1 / pivot


cdef inline void _support(const double* c, const double* a, double h, double r, double dx, double dy, double dz,
                          double nx, double ny, double nz, double* out) noexcept nogil:
    """Support point of cylinder (c, a, h, r) along d, projected on the plane of normal n (n = 0: none)."""
    cdef double da = dx * a[0] + dy * a[1] + dz * a[2]
    cdef double s = h if da >= 0 else -h
    cdef double wx = dx - da * a[0]
    cdef double wy = dy - da * a[1]
    cdef double wz = dz - da * a[2]
    cdef double wn = sqrt(wx * wx + wy * wy + wz * wz)
    cdef double px = c[0] + s * a[0]
    cdef double py = c[1] + s * a[1]
    cdef double pz = c[2] + s * a[2]
    if wn > 1e-300:
        px += r * wx / wn
        py += r * wy / wn
        pz += r * wz / wn
    cdef double pn = px * nx + py * ny + pz * nz
    out[0] = px - pn * nx
    out[1] = py - pn * ny
    out[2] = pz - pn * nz


cdef inline int _lu(double* A, int n, int* piv) noexcept nogil:
    """LU with partial pivoting of the row-major n x n A (n <= 3) in place, as OpenBLAS's
    left-looking ``getf2`` does it: returns LAPACK's info (0, or j + 1 for the first zero pivot).

    Column j: the earlier row swaps, then U above the diagonal (a one-term dot for n <= 3), then
    the rest of the column less L @ U (``gemv``: a sum accumulated by fused multiply-adds from 0,
    then subtracted), the first largest |entry| as pivot, the row swap and the scaling by 1 / pivot.
    """
    cdef int i, j, k, p, info = 0
    cdef double t, pv, rcp
    for j in range(n):
        for i in range(j):
            p = piv[i]
            if p != i:
                t = A[i * n + j]
                A[i * n + j] = A[p * n + j]
                A[p * n + j] = t
        for i in range(1, j):
            t = 0.0
            for k in range(i):
                t = t + A[i * n + k] * A[k * n + j]  # n <= 3: i == 1, a single product
            A[i * n + j] = A[i * n + j] - t
        if j > 0:
            for i in range(j, n):
                t = A[i * n] * A[j] + 0.0  # fma(l, u, 0.0): the product, -0 made +0
                for k in range(1, j):
                    t = fma(A[i * n + k], A[k * n + j], t)
                A[i * n + j] = A[i * n + j] - t
        p = j
        for i in range(j + 1, n):
            if fabs(A[i * n + j]) > fabs(A[p * n + j]):
                p = i
        piv[j] = p
        pv = A[p * n + j]
        if pv != 0.0:
            if p != j:
                for k in range(j + 1):
                    t = A[j * n + k]
                    A[j * n + k] = A[p * n + k]
                    A[p * n + k] = t
            if fabs(pv) >= _DBL_MIN:
                rcp = 1.0 / pv
                for i in range(j + 1, n):
                    A[i * n + j] = A[i * n + j] * rcp
            else:
                for i in range(j + 1, n):
                    A[i * n + j] = A[i * n + j] / pv
        elif info == 0:
            info = j + 1
    return info


cdef inline void _lu_solve(const double* A, int n, const int* piv, double* b) noexcept nogil:
    """Solve with the factors of ``_lu`` as OpenBLAS's ``getrs`` does for one right-hand side:
    the row swaps, then column-oriented forward (unit L) and back (U) substitution by ``axpy``
    (fused multiply-adds), dividing by the diagonal."""
    cdef int i, k, p
    cdef double t
    for i in range(n):
        p = piv[i]
        if p != i:
            t = b[i]
            b[i] = b[p]
            b[p] = t
    for i in range(n):
        for k in range(i + 1, n):
            b[k] = fma(-b[i], A[k * n + i], b[k])
    for i in range(n - 1, -1, -1):
        b[i] = b[i] / A[i * n + i]
        for k in range(i):
            b[k] = fma(-b[i], A[k * n + i], b[k])


cdef inline bint _degenerate(const double* A, int n, int info, double gmax) noexcept nogil:
    """Whether ``abs(np.linalg.det(G)) < 1e-24 * max(1.0, G.max() ** (n))``, on the factors of G,
    det being ``sign * exp(sum log |u_kk|)`` (0 when a pivot is zero). The product of the pivots
    decides when it is clearly on one side (both agree to 1e-12 relative); else the logs do."""
    cdef double pw, thr, prod, acc
    cdef int k
    if info > 0:
        return True  # det 0 < a positive threshold
    # float ** int by repeated squaring (x ** 3 = x * (x * x)), the threshold's bits
    if n == 1:
        pw = gmax
    elif n == 2:
        pw = gmax * gmax
    else:
        pw = gmax * (gmax * gmax)
    thr = 1e-24 * (pw if pw > 1.0 else 1.0)
    prod = fabs(A[0])
    for k in range(1, n):
        prod = prod * fabs(A[k * n + k])
    if prod > 1e-290 and prod < 1e290 and fabs(prod - thr) > 1e-9 * thr:
        return prod < thr
    acc = 0.0
    for k in range(n):
        acc = acc + log(fabs(A[k * n + k]))
    return exp(acc) < thr


cdef int _closest_on_simplex(const double* S, int m, double* bx, double* by, double* bz, int* keep) noexcept nogil:
    """Closest point to the origin of the simplex S[:m] (m <= 4, rows of 3), trying every face.

    Writes the point and the kept vertices' mask bits; returns 0, or 1 for a Gram system with
    an infinity or NaN (no solution: the caller raises LinAlgError).
    """
    cdef double best_d = INFINITY
    cdef double G[9]
    cdef double rhs[3]
    cdef double w[4]
    cdef double e[9]
    cdef int piv[3]
    cdef int idx[4]
    cdef int mask, q, i, j, k, info
    cdef double x, y, z, d, gmax, s
    cdef const double* p0
    cdef bint ok
    bx[0] = 0.0
    by[0] = 0.0
    bz[0] = 0.0
    keep[0] = 0
    for mask in range(1, 1 << m):
        q = 0
        for i in range(m):
            if mask & (1 << i):
                idx[q] = i
                q += 1
        p0 = S + 3 * idx[0]
        if q == 1:
            x = p0[0]
            y = p0[1]
            z = p0[2]
        else:
            k = q - 1
            for i in range(1, q):
                e[3 * (i - 1)] = S[3 * idx[i]] - p0[0]
                e[3 * (i - 1) + 1] = S[3 * idx[i] + 1] - p0[1]
                e[3 * (i - 1) + 2] = S[3 * idx[i] + 2] - p0[2]
            for i in range(k):
                rhs[i] = -(e[3 * i] * p0[0] + e[3 * i + 1] * p0[1] + e[3 * i + 2] * p0[2])
                for j in range(k):
                    G[i * k + j] = e[3 * i] * e[3 * j] + e[3 * i + 1] * e[3 * j + 1] + e[3 * i + 2] * e[3 * j + 2]
            gmax = G[0]
            for i in range(k * k):
                if not isfinite(G[i]):
                    return 1
                if G[i] > gmax:
                    gmax = G[i]
            info = _lu(G, k, piv)
            if _degenerate(G, k, info, gmax):
                continue  # a degenerate face: its points are covered by smaller ones
            for i in range(k):
                if not isfinite(rhs[i]):
                    return 1
            _lu_solve(G, k, piv, rhs)
            s = 0.0
            for i in range(k):
                s = s + rhs[i]
            w[0] = 1.0 - s
            for i in range(k):
                w[i + 1] = rhs[i]
            ok = True
            for i in range(q):
                if w[i] < -1e-12:
                    ok = False
            if not ok:
                continue
            x = 0.0
            y = 0.0
            z = 0.0
            for i in range(q):
                x = x + w[i] * S[3 * idx[i]]
                y = y + w[i] * S[3 * idx[i] + 1]
                z = z + w[i] * S[3 * idx[i] + 2]
        d = x * x + y * y + z * z
        if d < best_d - 1e-30 or (d <= best_d and q < 4):
            best_d = d
            bx[0] = x
            by[0] = y
            bz[0] = z
            keep[0] = mask
    return 0


cdef double gjk_c(const double* cA, const double* aA, double hA, double rA,
                  const double* cB, const double* aB, double hB, double rB,
                  double nx, double ny, double nz, double tol, bint stop_apart, int* err) noexcept nogil:
    """``gjk_distance``; ``err`` set to 1 (and the result meaningless) for a Gram system with an
    infinity or NaN (LinAlgError in Python)."""
    cdef double S[12]
    cdef double ta[3]
    cdef double tb[3]
    cdef double vx, vy, vz, vn, wx, wy, wz, vv, vnorm, px, py, pz
    cdef int m = 0
    cdef int it, i, q, keep
    err[0] = 0
    # start from the direction between the centres (projected)
    vx = cA[0] - cB[0]
    vy = cA[1] - cB[1]
    vz = cA[2] - cB[2]
    vn = vx * nx + vy * ny + vz * nz
    vx -= vn * nx
    vy -= vn * ny
    vz -= vn * nz
    if vx * vx + vy * vy + vz * vz == 0.0:
        if fabs(nx) < 0.9:
            vx = 1.0
            vy = 0.0
            vz = 0.0
        else:
            vx = 0.0
            vy = 1.0
            vz = 0.0
    for it in range(_MAX_ITER):
        _support(cA, aA, hA, rA, -vx, -vy, -vz, nx, ny, nz, ta)
        _support(cB, aB, hB, rB, vx, vy, vz, nx, ny, nz, tb)
        wx = ta[0] - tb[0]
        wy = ta[1] - tb[1]
        wz = ta[2] - tb[2]
        vv = vx * vx + vy * vy + vz * vz
        vnorm = sqrt(vv)
        # lower bound on the distance: the plane orthogonal to v through w
        if stop_apart and vnorm > 0 and (vx * wx + vy * wy + vz * wz) / vnorm > tol:
            return (vx * wx + vy * wy + vz * wz) / vnorm  # separated by more than tol
        if vnorm > 0 and vnorm - (vx * wx + vy * wy + vz * wz) / vnorm <= tol:
            return vnorm  # upper and lower bounds meet
        S[3 * m] = wx
        S[3 * m + 1] = wy
        S[3 * m + 2] = wz
        m += 1
        if _closest_on_simplex(S, m, &px, &py, &pz, &keep):
            err[0] = 1
            return 0.0
        q = 0
        for i in range(m):
            if keep & (1 << i):
                S[3 * q] = S[3 * i]
                S[3 * q + 1] = S[3 * i + 1]
                S[3 * q + 2] = S[3 * i + 2]
                q += 1
        m = q
        vx = px
        vy = py
        vz = pz
        if vx * vx + vy * vy + vz * vz <= tol * tol or m == 4:
            return 0.0
    return sqrt(vx * vx + vy * vy + vz * vz)


def _vec3(x, name):
    a = np.ascontiguousarray(x, dtype=np.float64).reshape(-1)
    if a.shape[0] < 3:
        raise ValueError(f"{name} needs 3 components, got {a.shape[0]}")
    return a


def _rows3(x, name):
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] < 3:
        raise ValueError(f"{name} must be (N, 3), got shape {a.shape}")
    return a


def _linalg_error():
    return np.linalg.LinAlgError("Array must not contain infs or NaNs.")


def gjk_distance(cA, aA, double hA, double rA, cB, aB, double hB, double rB, double nx, double ny, double nz,
                 double tol, bint stop_apart=True):
    """Distance between two cylinders (or their projections on the plane of normal n), to ``tol``.

    With ``stop_apart`` it returns as soon as a lower bound exceeds ``tol`` (that bound, not the
    distance): enough to decide contact, and much quicker for shapes far apart.
    """
    cdef const double[::1] ca = _vec3(cA, "cA")
    cdef const double[::1] aa = _vec3(aA, "aA")
    cdef const double[::1] cb = _vec3(cB, "cB")
    cdef const double[::1] ab = _vec3(aB, "aB")
    cdef int err
    cdef double d
    with nogil:
        d = gjk_c(&ca[0], &aa[0], hA, rA, &cb[0], &ab[0], hB, rB, nx, ny, nz, tol, stop_apart, &err)
    if err:
        raise _linalg_error()
    return d


def cylinders_distance_batch(cA, aA, double hA, double rA, cB, aB, double hB, double rB, normal, double tol):
    """Distances (N,) between cylinder A_i (centres (N, 3), axes (N, 3), h, r) and a fixed cylinder B,
    in 3D (normal = 0) or between their shadows on the plane of unit ``normal``."""
    cdef const double[:, ::1] ca = _rows3(cA, "cA")
    cdef const double[:, ::1] aa = _rows3(aA, "aA")
    cdef const double[::1] cb = _vec3(cB, "cB")
    cdef const double[::1] ab = _vec3(aB, "aB")
    cdef const double[::1] nrm = _vec3(normal, "normal")
    cdef Py_ssize_t n = ca.shape[0]
    if aa.shape[0] < n:
        raise ValueError(f"aA has {aa.shape[0]} rows for {n} centres")
    out_arr = np.empty(n)
    cdef double[::1] out = out_arr
    cdef Py_ssize_t i
    cdef int e
    cdef int bad = 0
    cdef double nx = nrm[0]
    cdef double ny = nrm[1]
    cdef double nz = nrm[2]
    if n == 0:
        return out_arr
    with nogil:
        for i in prange(n, schedule="guided"):
            e = 0  # assigned in the loop: private to each thread
            out[i] = gjk_c(&ca[i, 0], &aa[i, 0], hA, rA, &cb[0], &ab[0], hB, rB, nx, ny, nz, tol, True, &e)
            if e:
                bad += 1
    if bad:
        raise _linalg_error()
    return out_arr
