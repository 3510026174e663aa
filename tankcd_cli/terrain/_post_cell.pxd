# The arithmetic of a cell of posts that both layouts' kernels share (the grid's
# ``grid/_post_queries.pyx``, a DEM mesh's ``mesh/_point_queries.pyx``), inlined where cimported.

from cpython.pyport cimport PY_SSIZE_T_MIN
from libc.math cimport isfinite, NAN


cdef inline Py_ssize_t ifloor(double x) noexcept nogil:
    """``<Py_ssize_t>floor(x)`` without libm's floor (x86-64's baseline instruction set has no
    rounding instruction, so gcc would call the library for every point). Equal to it
    for every finite x in the int64 range; NaN and values outside it give the conversion's
    'indefinite' value PY_SSIZE_T_MIN, as ``<Py_ssize_t>floor(x)`` does."""
    cdef Py_ssize_t i = <Py_ssize_t>x  # truncation toward zero
    if <double>i > x and i != PY_SSIZE_T_MIN:
        i -= 1  # negative and not an integer
    return i


cdef inline void cell_from_posts(double sw, double se, double ne, double nw, double fx, double fy,
                                 double dx, double dy, double* z, double* gx, double* gy) noexcept nogil:
    """Height and gradient at fractions (fx, fy) of a cell with posts sw, se, ne, nw when all four
    are valid (the SW-NE split); NaN otherwise."""
    if not (isfinite(sw) and isfinite(se) and isfinite(ne) and isfinite(nw)):
        z[0] = NAN
        gx[0] = NAN
        gy[0] = NAN
        return
    if fx >= fy:
        z[0] = sw + fx * (se - sw) + fy * (ne - se)
        gx[0] = (se - sw) / dx
        gy[0] = (ne - se) / dy
    else:
        z[0] = sw + fy * (nw - sw) + fx * (ne - nw)
        gx[0] = (ne - nw) / dx
        gy[0] = (nw - sw) / dy


cdef inline void full_cell_c(const double* post_z, Py_ssize_t cols, Py_ssize_t wr, Py_ssize_t wc,
                             double fx, double fy, double dx, double dy,
                             double* z, double* gx, double* gy) noexcept nogil:
    """``full_cell`` on a C-contiguous (rows, cols) post raster (south row first), no bounds check:
    0 <= wr <= rows - 2 and 0 <= wc <= cols - 2."""
    cdef const double* south = post_z + wr * cols + wc
    cdef const double* north = south + cols
    cell_from_posts(south[0], south[1], north[1], north[0], fx, fy, dx, dy, z, gx, gy)
