# The compiled fixed-point CSV writer (fixed_text.py says what it writes).

import numpy as np

from cython.parallel cimport prange
from libc.math cimport isfinite, rint
from libc.stdlib cimport free, malloc
from libc.string cimport memmove

# rows a thread formats at a time; tables of fewer than two blocks are formatted serially
DEF _ROW_BLOCK = 8192


# two-digit pairs "00".."99": half the divisions of one digit at a time
cdef const char* _PAIRS = (b"00010203040506070809101112131415161718192021222324252627282930313233343536373839"
                           b"40414243444546474849505152535455565758596061626364656667686970717273747576777879"
                           b"8081828384858687888990919293949596979899")


cdef inline Py_ssize_t _put_int(unsigned char* out, Py_ssize_t pos, long long value, Py_ssize_t width) noexcept nogil:
    """Decimal digits of value >= 0, zero-padded to at least ``width``; returns the new position."""
    cdef unsigned long long v = <unsigned long long>value, probe = v, q, pair
    cdef Py_ssize_t digits = 1, k
    while probe >= 10:
        probe //= 10
        digits += 1
    if digits < width:
        digits = width
    k = pos + digits
    while v >= 100:
        q = v // 100
        pair = 2 * (v - q * 100)
        k -= 2
        out[k] = _PAIRS[pair]
        out[k + 1] = _PAIRS[pair + 1]
        v = q
    if v >= 10:
        k -= 2
        out[k] = _PAIRS[2 * v]
        out[k + 1] = _PAIRS[2 * v + 1]
    else:
        k -= 1
        out[k] = <unsigned char>(48 + v)
    while k > pos:  # the zero padding
        k -= 1
        out[k] = 48
    return pos + digits


# Python's floor division and modulo, for the cases the fast path leaves out
cdef inline long long _fdiv(long long a, long long b) noexcept nogil:
    cdef long long q = a / b
    if (a % b != 0) and ((a < 0) != (b < 0)):
        q -= 1
    return q


cdef inline long long _fmod(long long a, long long b) noexcept nogil:
    cdef long long m = a % b
    if m != 0 and ((m < 0) != (b < 0)):
        m += b
    return m


cdef Py_ssize_t _put_int_floor(unsigned char* out, Py_ssize_t pos, long long value, Py_ssize_t width) noexcept nogil:
    """``_put_int`` with floor semantics for any value (a negative one too, as Python's // and % give)."""
    cdef Py_ssize_t digits = 1, k
    cdef long long probe = value
    while probe >= 10:
        probe = _fdiv(probe, 10)
        digits += 1
    if digits < width:
        digits = width
    for k in range(digits - 1, -1, -1):
        out[pos + k] = <unsigned char>(48 + _fmod(value, 10))
        value = _fdiv(value, 10)
    return pos + digits


cdef Py_ssize_t _format(const double* numbers, Py_ssize_t n, Py_ssize_t m, const long long* decimals, Py_ssize_t ndec,
                        const long long* codes, Py_ssize_t ncodes, const unsigned char* labels, Py_ssize_t nlabels,
                        Py_ssize_t lwidth, const long long* label_len, Py_ssize_t nlen, const long long* kinds,
                        const long long* index, Py_ssize_t ncols,
                        unsigned char* out, long long* row_ends) noexcept nogil:
    """The rows' text into ``out``; returns the bytes written, -1 for a column whose
    10 ** decimals is 0 in int64 (decimals < 0 or >= 64: the caller raises ZeroDivisionError), -2 when
    out of memory. ``row_ends`` (NULL: none) gets each row's end in ``out``."""
    cdef Py_ssize_t pos = 0, i, c, k, length
    cdef long long j, code, d, scale, r, t
    cdef unsigned long long p
    cdef double v
    cdef const unsigned char* label
    # 10 ** d for each column as an int64 power: wrapping past d = 18, 0 for d < 0
    cdef long long* scales = <long long*>malloc((ndec if ndec > 0 else 1) * sizeof(long long))
    if scales == NULL:
        return -2
    for j in range(ndec):
        d = decimals[j]
        p = 1
        for t in range(d):
            p *= 10
        scales[j] = <long long>p if d >= 0 else 0
    for i in range(n):
        for c in range(ncols):
            if c > 0:
                out[pos] = 44  # ','
                pos += 1
            j = index[c]
            if kinds[c] == 1:
                # negative indices count from the end, as numpy's do
                code = codes[i * ncodes + (j + ncodes if j < 0 else j)]
                length = label_len[code + nlen if code < 0 else code]
                label = labels + (code + nlabels if code < 0 else code) * lwidth
                for k in range(length):
                    out[pos + k] = label[k]
                pos += length
                continue
            v = numbers[i * m + (j + m if j < 0 else j)]
            if not isfinite(v):
                continue
            if j < 0:
                j += ndec
            d = decimals[j]
            scale = scales[j]
            if scale == 0:
                free(scales)
                return -1
            r = <long long>rint(v * <double>scale)
            if r < 0:
                out[pos] = 45  # '-'
                pos += 1
                r = <long long>(0ULL - <unsigned long long>r)
            if scale > 0 and r >= 0:
                pos = _put_int(out, pos, r / scale, 1)
                if d > 0:
                    out[pos] = 46  # '.'
                    pos += 1
                    pos = _put_int(out, pos, r % scale, d)
            else:  # 10 ** d wrapped (d > 18) or r = -2**63: floor arithmetic, digit for digit
                pos = _put_int_floor(out, pos, _fdiv(r, scale), 1)
                if d > 0:
                    out[pos] = 46
                    pos += 1
                    pos = _put_int_floor(out, pos, _fmod(r, scale), d)
        out[pos] = 10  # '\n'
        pos += 1
        if row_ends != NULL:
            row_ends[i] = pos
    free(scales)
    return pos


def format_table(numbers, decimals, codes, labels, label_len, kinds, index, out, Py_ssize_t row_bound=0,
                 row_ends=None):
    """Write rows of CSV text into ``out`` (uint8); returns the number of bytes written.

    numbers : (N, M) float64; decimals : (M,) int64 digits after the point (0: an integer)
    codes : (N, L) int64 label codes into labels (K, W) uint8 / label_len (K,)
    kinds, index : (C,) the output columns: kind 0 is numbers[:, index], kind 1 is codes[:, index]
    ``out`` must hold the text (unchecked, see ``table_text`` for a bound).
    row_bound : when > 0, the most bytes any row's text takes (``out`` then holds N x row_bound):
        blocks of rows are formatted in parallel, each at its own N x row_bound place, and then
        moved together in order; the same bytes as the serial pass (each row's text depends on
        that row alone).
    row_ends : None, or an (N,) int64 array that gets each row's end in ``out`` (the bytes before
        the next row's first).
    """
    cdef const double[:, ::1] num = np.ascontiguousarray(numbers, dtype=np.float64)
    cdef const long long[::1] dec = np.ascontiguousarray(decimals, dtype=np.int64)
    cdef const long long[:, ::1] cod = np.ascontiguousarray(codes, dtype=np.int64)
    cdef const unsigned char[:, ::1] lab = np.ascontiguousarray(labels, dtype=np.uint8)
    cdef const long long[::1] llen = np.ascontiguousarray(label_len, dtype=np.int64)
    cdef const long long[::1] kin = np.ascontiguousarray(kinds, dtype=np.int64)
    cdef const long long[::1] idx = np.ascontiguousarray(index, dtype=np.int64)
    target = out
    if not (isinstance(out, np.ndarray) and out.dtype == np.uint8 and out.flags.c_contiguous and out.ndim == 1):
        target = np.ascontiguousarray(out, dtype=np.uint8).ravel().copy()
    cdef unsigned char[::1] buf = target
    cdef Py_ssize_t used
    cdef Py_ssize_t ncols = min(kin.shape[0], idx.shape[0])
    cdef const double* p_num = &num[0, 0] if num.shape[0] > 0 and num.shape[1] > 0 else NULL
    cdef const long long* p_dec = &dec[0] if dec.shape[0] > 0 else NULL
    cdef const long long* p_cod = &cod[0, 0] if cod.shape[0] > 0 and cod.shape[1] > 0 else NULL
    cdef const unsigned char* p_lab = &lab[0, 0] if lab.shape[0] > 0 and lab.shape[1] > 0 else NULL
    cdef const long long* p_llen = &llen[0] if llen.shape[0] > 0 else NULL
    cdef const long long* p_kin = &kin[0] if kin.shape[0] > 0 else NULL
    cdef const long long* p_idx = &idx[0] if idx.shape[0] > 0 else NULL
    cdef unsigned char* p_out = &buf[0] if buf.shape[0] > 0 else NULL
    cdef long long[::1] ends_view
    cdef long long* p_ends = NULL
    if row_ends is not None:
        ends_view = row_ends
        if ends_view.shape[0] < num.shape[0]:
            raise ValueError("row_ends must hold one end a row")
        if ends_view.shape[0] > 0:
            p_ends = &ends_view[0]
    cdef Py_ssize_t n = num.shape[0], nblock = (n + _ROW_BLOCK - 1) // _ROW_BLOCK, b, r0, r1, k
    cdef Py_ssize_t* block_used
    if row_bound > 0 and nblock >= 2 and p_num != NULL and (cod.shape[1] == 0 or p_cod != NULL):
        block_used = <Py_ssize_t*>malloc(nblock * sizeof(Py_ssize_t))
        if block_used == NULL:
            raise MemoryError()
        with nogil:
            for b in prange(nblock, schedule="static"):
                r0 = b * _ROW_BLOCK
                r1 = r0 + _ROW_BLOCK if r0 + _ROW_BLOCK < n else n
                block_used[b] = _format(p_num + r0 * num.shape[1], r1 - r0, num.shape[1], p_dec, dec.shape[0],
                                        p_cod + r0 * cod.shape[1] if p_cod != NULL else NULL, cod.shape[1], p_lab,
                                        lab.shape[0], lab.shape[1], p_llen, llen.shape[0], p_kin, p_idx, ncols,
                                        p_out + r0 * row_bound, p_ends + r0 if p_ends != NULL else NULL)
            used = 0
            for b in range(nblock):
                if block_used[b] < 0:
                    used = block_used[b]
                    break
                # blocks move down (each starts at or after where it goes): memmove, in order
                memmove(p_out + used, p_out + b * _ROW_BLOCK * row_bound, block_used[b])
                if p_ends != NULL:
                    r0 = b * _ROW_BLOCK
                    r1 = r0 + _ROW_BLOCK if r0 + _ROW_BLOCK < n else n
                    for k in range(r0, r1):
                        p_ends[k] += used
                used += block_used[b]
        free(block_used)
    else:
        with nogil:
            used = _format(p_num, num.shape[0], num.shape[1], p_dec, dec.shape[0], p_cod, cod.shape[1], p_lab,
                           lab.shape[0], lab.shape[1], p_llen, llen.shape[0], p_kin, p_idx, ncols, p_out, p_ends)
    if used == -2:
        raise MemoryError()
    if used < 0:
        raise ZeroDivisionError("integer division or modulo by zero")
    if target is not out:
        out[...] = np.asarray(target).reshape(np.shape(out))
    return used
