"""Exact triangle-triangle intersection, compiled ahead of time (Cython).

The test itself is ``tri_tri_c`` in ``_triangles.pxd`` (nogil, inlined into the modules that
cimport it); this module gives it its Python face. See :mod:`tankcd_cli.geometry.triangles`.
"""

cimport numpy as cnp

import numpy as np

from tankcd_cli.geometry._triangles cimport tri_tri_c, tri_tri_distance_c

cnp.import_array()

REL_EPS = 1e-12


cdef inline bint _is_f64(object a, int ndim, bint writeable):
    """``a`` is a C-contiguous float64 ndarray of ``ndim`` dimensions (and writeable if asked)."""
    if not cnp.PyArray_Check(a):
        return False
    cdef cnp.ndarray arr = <cnp.ndarray>a
    return (cnp.PyArray_TYPE(arr) == cnp.NPY_DOUBLE and cnp.PyArray_NDIM(arr) == ndim
            and cnp.PyArray_IS_C_CONTIGUOUS(arr) and (not writeable or cnp.PyArray_ISWRITEABLE(arr)))


cdef cnp.ndarray _triangle(object T):
    """Triangle T as a (3, 3) C-contiguous float64 array (its first 3 x 3 values; a larger array is cut)."""
    cdef cnp.ndarray arr
    if _is_f64(T, 2, False):
        arr = <cnp.ndarray>T
        if cnp.PyArray_DIM(arr, 0) == 3 and cnp.PyArray_DIM(arr, 1) == 3:
            return arr
    arr = np.asarray(T, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[0] < 3 or arr.shape[1] < 3:
        raise ValueError("tri_tri needs two (3, 3) triangles")
    return np.ascontiguousarray(arr[:3, :3])


def tri_tri(P, Q, out, scratch=None):
    """Whether closed triangles P and Q (3, 3) meet; if so, ``out`` (3,) receives a common point.

    ``scratch`` (6, 3), if given, receives the working values (where each triangle crosses the
    other's plane, and its vertices' distances to it); the test needs no allocation either way.
    """
    cdef cnp.ndarray p = _triangle(P)
    cdef cnp.ndarray q = _triangle(Q)
    cdef double out_buf[3]
    cdef double scratch_buf[18]
    cdef double* out_ptr = out_buf
    cdef double* scratch_ptr = scratch_buf
    cdef cnp.ndarray tmp_scratch = None
    if _is_f64(out, 1, True) and cnp.PyArray_DIM(<cnp.ndarray>out, 0) >= 3:
        out_ptr = <double*>cnp.PyArray_DATA(<cnp.ndarray>out)
    elif np.shape(out)[0] < 3:
        raise ValueError("tri_tri needs an output of 3 values")
    if scratch is not None:
        if _is_f64(scratch, 2, True):
            tmp_scratch = <cnp.ndarray>scratch
        else:  # work on a float64 copy and write it back into the caller's array
            tmp_scratch = np.array(scratch, dtype=np.float64, order="C", ndmin=2)
        if tmp_scratch.shape[0] < 6 or tmp_scratch.shape[1] != 3:
            raise ValueError("tri_tri needs a (6, 3) scratch")
        scratch_ptr = <double*>cnp.PyArray_DATA(tmp_scratch)
    cdef bint hit = tri_tri_c(<const double*>cnp.PyArray_DATA(p), <const double*>cnp.PyArray_DATA(q), out_ptr,
                              scratch_ptr)
    if tmp_scratch is not None and tmp_scratch is not scratch:
        scratch[...] = tmp_scratch
    if hit and out_ptr == out_buf:
        out[:3] = [out_buf[0], out_buf[1], out_buf[2]]
    return hit


def tri_distance(P, Q):
    """The distance between closed triangles P and Q (3, 3) and a closest pair of points (3,), (3,)
    on them (``tri_tri_distance_c``; +inf and NaN points when either is degenerate)."""
    cdef cnp.ndarray p = _triangle(P)
    cdef cnp.ndarray q = _triangle(Q)
    cdef double cp[3]
    cdef double cq[3]
    cdef double scratch[18]
    cdef double d = tri_tri_distance_c(<const double*>cnp.PyArray_DATA(p), <const double*>cnp.PyArray_DATA(q),
                                       cp, cq, scratch)
    if d == float("inf"):
        return d, np.full(3, np.nan), np.full(3, np.nan)
    return d, np.array([cp[0], cp[1], cp[2]]), np.array([cq[0], cq[1], cq[2]])
