# The compiled CSV chunk parser (see csv_kernels.py for the contract): Clinger's fast path, else "not ok".

import numpy as np

cimport numpy as cnp

from tankcd_cli.io._decimal cimport decimal_at, is_blank

cnp.import_array()


cdef bint _parse(const unsigned char* buf, Py_ssize_t n, Py_ssize_t rows, Py_ssize_t width,
                 const double* pow10, double* out) noexcept nogil:
    """The table into ``out`` (rows * width, row-major); False at the first cell off the fast path."""
    cdef Py_ssize_t pos = 0, r, c
    for r in range(rows):
        for c in range(width):
            while pos < n and is_blank(buf[pos]):
                pos += 1
            pos = decimal_at(buf, pos, n, pow10, &out[r * width + c])
            if pos < 0:
                return False
            while pos < n and is_blank(buf[pos]):
                pos += 1
            # the separator: a comma between cells, a line end after the last
            if c < width - 1:
                if pos >= n or buf[pos] != 44:
                    return False
                pos += 1
            else:
                if pos < n and buf[pos] == 13:  # '\r'
                    pos += 1
                if pos < n:
                    if buf[pos] != 10:  # '\n'
                        return False
                    pos += 1
                elif r != rows - 1:
                    return False
    return pos == n


def parse_table(buf, rows, width, pow10):
    """Parse ``rows`` lines of ``width`` comma-separated decimals from bytes; returns (values, ok).

    buf : (n,) uint8 text; pow10 : (23,) float64 with pow10[k] == 10.0 ** k (read unchecked for k <= 22).
    values : (rows, width) float64, filled only where ok is True.
    """
    cdef Py_ssize_t nrows = rows, ncols = width
    cdef const unsigned char[::1] text
    cdef const double[::1] p10
    try:  # the usual contiguous uint8 / float64 arrays as they are, anything else converted
        text = buf
    except (TypeError, ValueError):
        text = np.ascontiguousarray(buf, dtype=np.uint8)
    try:
        p10 = pow10
    except (TypeError, ValueError):
        p10 = np.ascontiguousarray(pow10, dtype=np.float64)
    cdef cnp.ndarray out = np.empty((nrows, ncols))
    cdef Py_ssize_t n = text.shape[0]
    cdef bint ok
    cdef const unsigned char* b = &text[0] if n > 0 else NULL
    cdef const double* p = &p10[0] if p10.shape[0] > 0 else NULL
    cdef double* o = <double*>cnp.PyArray_DATA(out)
    with nogil:
        ok = _parse(b, n, nrows, ncols, p, o)
    return out, bool(ok)
