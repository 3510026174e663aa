# Two trees as the compiled walks read them (shared by _traverse.pyx and _sweep.pyx).
#
# ``fill_trees`` points a ``Trees`` at the arrays of two ``bvh.build.Tree`` objects (A moving: its
# nodes' parallelepipeds; B static: its nodes' k-DOPs) and returns the arrays it points into, which
# the caller keeps alive for as long as it walks.

cimport numpy as cnp
from libc.math cimport fabs, INFINITY
from libc.stdint cimport int64_t


ctypedef struct Trees:
    # tree A (moving): triangles in its own frame, its nodes' parallelepipeds (n, T, 3)
    const double* a_tri
    const int64_t* a_idx
    const int64_t* a_left
    const int64_t* a_right
    const int64_t* a_start
    const int64_t* a_count
    const int64_t* a_depth
    int64_t a_levels
    const double* a_centre
    const double* a_half
    const double* a_size
    # tree B (static): triangles in its frame, node k-DOPs (n, nb)
    const double* b_tri
    const int64_t* b_idx
    const double* b_lo
    const double* b_hi
    Py_ssize_t nb
    const int64_t* b_left
    const int64_t* b_right
    const int64_t* b_start
    const int64_t* b_count
    const int64_t* b_depth
    int64_t b_levels
    const double* b_size
    Py_ssize_t K  # slab directions
    Py_ssize_t T  # slab triples


cdef inline const double* _dp(cnp.ndarray a):
    return <const double*>cnp.PyArray_DATA(a) if cnp.PyArray_SIZE(a) else NULL


cdef inline cnp.ndarray f64(object v):
    import numpy  # a .pxd has no module namespace of its own
    return numpy.ascontiguousarray(v, dtype=numpy.float64)


cdef inline cnp.ndarray i64(object v):
    import numpy
    return numpy.ascontiguousarray(v, dtype=numpy.int64)


cdef inline const int64_t* _ip(cnp.ndarray a):
    return <const int64_t*>cnp.PyArray_DATA(a) if cnp.PyArray_SIZE(a) else NULL


cdef inline tuple fill_trees(Trees* tr, object a, object b, Py_ssize_t K, Py_ssize_t T):
    """Point ``tr`` at trees a (moving) and b (static); returns the arrays to keep alive."""
    cdef cnp.ndarray a_tri = f64(a.triangles), a_idx = i64(a.source_index), a_left = i64(a.left)
    cdef cnp.ndarray a_right = i64(a.right), a_start = i64(a.start), a_count = i64(a.count)
    cdef cnp.ndarray a_depth = i64(a.depth), a_centre = f64(a.centre), a_half = f64(a.half)
    # a node's size (the sum of its AABB's sides) decides which node of a pair to open
    cdef cnp.ndarray a_size = f64((f64(a.hi)[:, :3] - f64(a.lo)[:, :3]).sum(axis=1))
    cdef cnp.ndarray b_tri = f64(b.triangles), b_idx = i64(b.source_index), b_lo = f64(b.lo), b_hi = f64(b.hi)
    cdef cnp.ndarray b_left = i64(b.left), b_right = i64(b.right), b_start = i64(b.start)
    cdef cnp.ndarray b_count = i64(b.count), b_depth = i64(b.depth)
    cdef cnp.ndarray b_size = f64((f64(b.hi)[:, :3] - f64(b.lo)[:, :3]).sum(axis=1))
    if a_centre.shape[1] != T or a_half.shape[1] != T or b_hi.shape[1] != b_lo.shape[1] or b_lo.shape[1] < K:
        raise ValueError("tree volumes do not match the slab directions")
    tr.a_tri, tr.a_idx, tr.a_left, tr.a_right = _dp(a_tri), _ip(a_idx), _ip(a_left), _ip(a_right)
    tr.a_start, tr.a_count, tr.a_depth = _ip(a_start), _ip(a_count), _ip(a_depth)
    tr.a_levels = a.aabb_levels
    tr.a_centre, tr.a_half, tr.a_size = _dp(a_centre), _dp(a_half), _dp(a_size)
    tr.b_tri, tr.b_idx, tr.b_lo, tr.b_hi = _dp(b_tri), _ip(b_idx), _dp(b_lo), _dp(b_hi)
    tr.nb = b_lo.shape[1]
    tr.b_left, tr.b_right, tr.b_start = _ip(b_left), _ip(b_right), _ip(b_start)
    tr.b_count, tr.b_depth = _ip(b_count), _ip(b_depth)
    tr.b_levels = b.aabb_levels
    tr.b_size = _dp(b_size)
    tr.K = K
    tr.T = T
    return (a_tri, a_idx, a_left, a_right, a_start, a_count, a_depth, a_centre, a_half, a_size,
            b_tri, b_idx, b_lo, b_hi, b_left, b_right, b_start, b_count, b_depth, b_size)


cdef inline double tree_reach(const Trees* tr) noexcept nogil:
    """The largest coordinate of either tree's root bounds (the scale of the walks' round-off margins)."""
    cdef double reach = 0.0
    cdef double v
    cdef Py_ssize_t i
    for i in range(3):
        v = fabs(tr.a_centre[i]) + fabs(tr.a_half[i])
        reach = v if v > reach else reach
        v = fabs(tr.b_lo[i])
        reach = v if v > reach else reach
        v = fabs(tr.b_hi[i])
        reach = v if v > reach else reach
    return reach


cdef inline bint nodes_disjoint(const Trees* tr, int64_t a, int64_t b, const double* f, const double* g,
                                const double* shift, double margin) noexcept nogil:
    """Whether node a of A (moved into B's frame) and node b of B are more than ``margin`` apart
    along one of the slab directions: then no pair of their triangles is within ``margin``.

    f (K, 3): the slab directions in A's frame; g (T, K, 3): the same through the inverses of A's
    parallelepiped triples; shift (K,): A's translation along each direction. Near the roots
    (depth below either tree's ``aabb_levels``) only the three axis slabs and A's first triple
    are tested. The walks of _traverse.pyx and _sweep.pyx share this one test, so they drop the
    same pairs of nodes (bit for bit) at the same margin."""
    cdef bint aabb = tr.a_depth[a] < tr.a_levels or tr.b_depth[b] < tr.b_levels
    cdef Py_ssize_t K = tr.K
    cdef Py_ssize_t T = tr.T
    cdef Py_ssize_t nd = 3 if aabb else K
    cdef Py_ssize_t nt = 1 if aabb else T
    cdef Py_ssize_t i, t
    cdef double best_lo, best_hi, c, r
    cdef const double* ac
    cdef const double* ah
    cdef const double* gt
    cdef const double* fi
    for i in range(nd):
        best_lo = -INFINITY
        best_hi = INFINITY
        fi = f + 3 * i
        for t in range(nt):
            ac = tr.a_centre + (a * T + t) * 3
            ah = tr.a_half + (a * T + t) * 3
            gt = g + (t * K + i) * 3
            c = fi[0] * ac[0] + fi[1] * ac[1] + fi[2] * ac[2]
            r = fabs(gt[0]) * ah[0] + fabs(gt[1]) * ah[1] + fabs(gt[2]) * ah[2]
            if c - r > best_lo:
                best_lo = c - r
            if c + r < best_hi:
                best_hi = c + r
        if (best_lo + shift[i] > tr.b_hi[b * tr.nb + i] + margin
                or best_hi + shift[i] < tr.b_lo[b * tr.nb + i] - margin):
            return True
    return False
