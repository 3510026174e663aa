# Small dense linear algebra, compiled inline into the kernels that cimport it
# (terrain/curvature/_jet_fit.pyx): the smallest eigenvector of a symmetric 3 x 3 matrix, and
# symmetric systems of at most SMALL_MAX unknowns by Cholesky or by LU with partial pivoting.
# Each runs its arithmetic in one fixed order (no fused multiply-add: setup.py builds with
# -ffp-contract=off), so the results do not depend on where they are inlined.

from libc.math cimport M_PI, acos, cos, fabs, sqrt

cdef enum:
    SMALL_MAX = 14    # unknowns of the largest system solved (a quartic jet's 14 monomials)


cdef inline void eig_jacobi(double* A, double* out) noexcept nogil:
    """Unit eigenvector of the smallest eigenvalue of the symmetric 3 x 3 matrix A (row-major,
    overwritten): cyclic Jacobi rotations until the off-diagonal vanishes to rounding."""
    cdef double Vm[9]
    cdef int i, p, q, r, sweep, best
    cdef double apq, app, aqq, theta, t, c, s, tau, g, h, arp, arq, vrp, vrq
    for i in range(9):
        Vm[i] = 0.0
    Vm[0] = 1.0
    Vm[4] = 1.0
    Vm[8] = 1.0
    for sweep in range(64):
        if fabs(A[1]) + fabs(A[2]) + fabs(A[5]) == 0.0:
            break
        for p in range(2):
            for q in range(p + 1, 3):
                apq = A[3 * p + q]
                if apq == 0.0:
                    continue
                app = A[3 * p + p]
                aqq = A[3 * q + q]
                g = 100.0 * fabs(apq)
                if sweep > 3 and fabs(app) + g == fabs(app) and fabs(aqq) + g == fabs(aqq):
                    A[3 * p + q] = 0.0
                    A[3 * q + p] = 0.0
                    continue
                h = aqq - app
                if fabs(h) + g == fabs(h):
                    t = apq / h
                else:
                    theta = 0.5 * h / apq
                    t = 1.0 / (fabs(theta) + sqrt(1.0 + theta * theta))
                    if theta < 0.0:
                        t = -t
                c = 1.0 / sqrt(1.0 + t * t)
                s = t * c
                tau = s / (1.0 + c)
                A[3 * p + p] = app - t * apq
                A[3 * q + q] = aqq + t * apq
                A[3 * p + q] = 0.0
                A[3 * q + p] = 0.0
                for r in range(3):
                    if r != p and r != q:
                        arp = A[3 * r + p]
                        arq = A[3 * r + q]
                        A[3 * r + p] = arp - s * (arq + tau * arp)
                        A[3 * r + q] = arq + s * (arp - tau * arq)
                        A[3 * p + r] = A[3 * r + p]
                        A[3 * q + r] = A[3 * r + q]
                for r in range(3):
                    vrp = Vm[3 * r + p]
                    vrq = Vm[3 * r + q]
                    Vm[3 * r + p] = vrp - s * (vrq + tau * vrp)
                    Vm[3 * r + q] = vrq + s * (vrp - tau * vrq)
    best = 0
    for i in range(1, 3):
        if A[4 * i] < A[4 * best]:
            best = i
    for r in range(3):
        out[r] = Vm[3 * r + best]


cdef inline double charpoly(const double* A, double lam, double* slope) noexcept nogil:
    """det(A - lam I) and its derivative in lam."""
    cdef double b0 = A[0] - lam, b1 = A[4] - lam, b2 = A[8] - lam
    cdef double m0 = b1 * b2 - A[5] * A[5], m1 = b0 * b2 - A[2] * A[2], m2 = b0 * b1 - A[1] * A[1]
    slope[0] = -(m0 + m1 + m2)
    return b0 * m0 - A[1] * (A[1] * b2 - A[5] * A[2]) + A[2] * (A[1] * A[5] - b1 * A[2])


cdef inline void eig_smallest(double* A, double* out) noexcept nogil:
    """Unit eigenvector of the smallest eigenvalue of the symmetric 3 x 3 matrix A (row-major;
    overwritten when the fallback runs). The eigenvalues in closed form (the trigonometric
    solution of the characteristic cubic), the smallest polished by Newton's method, the vector
    as the longest cross product of two rows of A - lam I: accurate to rounding over the gap to
    the next eigenvalue. Where that gap is small against the spread (a line or a point rather
    than a surface), cyclic Jacobi."""
    cdef double q, p1, p2, p, b00, b11, b22, r, phi, l0, l1, l2, f, fp, spread
    cdef double r0[3]
    cdef double r1[3]
    cdef double r2[3]
    cdef double c[3]
    cdef double best[3]
    cdef double nb, nc
    cdef int it, i
    p1 = A[1] * A[1] + A[2] * A[2] + A[5] * A[5]
    q = (A[0] + A[4] + A[8]) / 3.0
    b00 = A[0] - q
    b11 = A[4] - q
    b22 = A[8] - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    if not (p2 > 0.0) or p2 != p2 + 0.0 * p2:
        eig_jacobi(A, out)
        return
    p = sqrt(p2 / 6.0)
    r = (b00 * (b11 * b22 - A[5] * A[5]) - A[1] * (A[1] * b22 - A[5] * A[2])
         + A[2] * (A[1] * A[5] - b11 * A[2])) / (2.0 * p * p * p)
    if r <= -1.0:
        phi = M_PI / 3.0
    elif r >= 1.0:
        phi = 0.0
    else:
        phi = acos(r) / 3.0
    l2 = q + 2.0 * p * cos(phi)
    l0 = q + 2.0 * p * cos(phi + 2.0 * M_PI / 3.0)
    for it in range(3):
        f = charpoly(A, l0, &fp)
        if fp == 0.0:
            break
        l0 = l0 - f / fp
    l1 = 3.0 * q - l0 - l2
    spread = l2 - l0
    if not (l1 - l0 > 1e-4 * spread) or not (spread > 0.0):
        eig_jacobi(A, out)
        return
    for i in range(3):
        r0[i] = A[i]
        r1[i] = A[3 + i]
        r2[i] = A[6 + i]
    r0[0] -= l0
    r1[1] -= l0
    r2[2] -= l0
    best[0] = r0[1] * r1[2] - r0[2] * r1[1]
    best[1] = r0[2] * r1[0] - r0[0] * r1[2]
    best[2] = r0[0] * r1[1] - r0[1] * r1[0]
    nb = best[0] * best[0] + best[1] * best[1] + best[2] * best[2]
    c[0] = r0[1] * r2[2] - r0[2] * r2[1]
    c[1] = r0[2] * r2[0] - r0[0] * r2[2]
    c[2] = r0[0] * r2[1] - r0[1] * r2[0]
    nc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    if nc > nb:
        best[0] = c[0]
        best[1] = c[1]
        best[2] = c[2]
        nb = nc
    c[0] = r1[1] * r2[2] - r1[2] * r2[1]
    c[1] = r1[2] * r2[0] - r1[0] * r2[2]
    c[2] = r1[0] * r2[1] - r1[1] * r2[0]
    nc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    if nc > nb:
        best[0] = c[0]
        best[1] = c[1]
        best[2] = c[2]
        nb = nc
    # the rows span the plane normal to the vector with singular values l1 - l0, l2 - l0
    if not (nb > 0.01 * (l1 - l0) * (l1 - l0) * spread * spread):
        eig_jacobi(A, out)
        return
    nb = sqrt(nb)
    out[0] = best[0] / nb
    out[1] = best[1] / nb
    out[2] = best[2] / nb


cdef inline bint cholesky_solve(double* M, double* rhs, double* D, const int count) noexcept nogil:
    """Solve M x = rhs (M symmetric, full) by Cholesky, right-looking (independent updates, not
    dot-product chains) into the lower triangle; the strict upper triangle keeps M. False when a
    pivot is not positive (rhs untouched then)."""
    cdef double L[SMALL_MAX]
    cdef double inv[SMALL_MAX]
    cdef double y[SMALL_MAX]
    cdef double tmp, f
    cdef double* row
    cdef int c, r, b
    for c in range(count):
        tmp = M[c * count + c]
        if not (tmp > 0.0):
            return False
        tmp = sqrt(tmp)
        M[c * count + c] = tmp
        inv[c] = 1.0 / tmp
        for r in range(c + 1, count):
            L[r] = M[r * count + c] / tmp
            M[r * count + c] = L[r]
        for r in range(c + 1, count):
            f = L[r]
            row = M + r * count
            for b in range(c + 1, r + 1):
                row[b] -= f * L[b]
    for c in range(count):
        y[c] = rhs[c]
    for c in range(count):  # L y = rhs
        y[c] = y[c] * inv[c]
        f = y[c]
        for r in range(c + 1, count):
            y[r] -= M[r * count + c] * f
    for c in range(count - 1, -1, -1):  # L^T x = y
        y[c] = y[c] * inv[c]
        f = y[c]
        for r in range(c):
            y[r] -= M[c * count + r] * f
    for c in range(count):
        rhs[c] = y[c]
    return True


cdef inline bint lu_solve(double* M, double* rhs, int count) noexcept nogil:
    """Solve with LU and partial pivoting (numpy's solve) from the upper triangle of M (symmetric).
    False when a pivot is zero."""
    cdef int a, b, c, r, piv
    cdef double big, f, tmp
    for a in range(count):
        for b in range(a):
            M[a * count + b] = M[b * count + a]
    for c in range(count):
        piv = c
        big = fabs(M[c * count + c])
        for r in range(c + 1, count):
            if fabs(M[r * count + c]) > big:
                big = fabs(M[r * count + c])
                piv = r
        if big == 0.0:
            return False
        if piv != c:
            for b in range(count):
                tmp = M[c * count + b]
                M[c * count + b] = M[piv * count + b]
                M[piv * count + b] = tmp
            tmp = rhs[c]
            rhs[c] = rhs[piv]
            rhs[piv] = tmp
        for r in range(c + 1, count):
            f = M[r * count + c] / M[c * count + c]
            if f != 0.0:
                for b in range(c + 1, count):
                    M[r * count + b] -= f * M[c * count + b]
                rhs[r] -= f * rhs[c]
    for c in range(count - 1, -1, -1):
        tmp = rhs[c]
        for b in range(c + 1, count):
            tmp -= M[c * count + b] * rhs[b]
        rhs[c] = tmp / M[c * count + c]
    return True
