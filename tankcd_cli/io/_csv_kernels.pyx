# The compiled CSV chunk parser (csv_kernels.py says what it reads and returns): Clinger's fast path, else "not ok".

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


# -- trajectory rows: any separator, a text column, ISO 8601 times, read straight from bytes ------------------
from libc.stdint cimport int64_t, uint64_t
from libc.stdlib cimport free, malloc, realloc, strtod
from libc.string cimport memchr, memcmp, memcpy
from libc.math cimport isfinite


cdef inline bint _blank(unsigned char ch, unsigned char sep) noexcept nogil:
    """A blank around a cell: a space, or a tab where the tab is not the separator."""
    return ch == 32 or (ch == 9 and sep != 9)


cdef inline int _two(const unsigned char* b, Py_ssize_t p) noexcept nogil:
    """The two digits at p as a number, or -1."""
    if 48 <= b[p] <= 57 and 48 <= b[p + 1] <= 57:
        return (b[p] - 48) * 10 + (b[p + 1] - 48)
    return -1


cdef inline int _month_days(long long y, int m) noexcept nogil:
    if m == 2:
        return 29 if (y % 4 == 0 and (y % 100 != 0 or y % 400 == 0)) else 28
    if m == 4 or m == 6 or m == 9 or m == 11:
        return 30
    return 31


cdef inline long long _days_from_civil(long long y, int m, int d) noexcept nogil:
    """Days from 1970-01-01 to the proleptic Gregorian date (year >= 1): H. Hinnant's algorithm."""
    cdef long long era, yoe, doy, doe
    if m <= 2:
        y -= 1
    era = y // 400  # y >= 0 here
    yoe = y - era * 400
    doy = (153 * (m + (-3 if m > 2 else 9)) + 2) // 5 + d - 1
    doe = yoe * 365 + yoe // 4 - yoe // 100 + doy
    return era * 146097 + doe - 719468


cdef bint _iso_time(const unsigned char* b, Py_ssize_t p, Py_ssize_t e, int64_t* sec, int64_t* ns) noexcept nogil:
    """``YYYY-MM-DD(T|t| )hh:mm:ss[.f{1,9}][Z|z|(+|-)hh[[:]mm]]`` exactly over [p, e) -> whole seconds since
    1970 (UTC: the offset taken off; no zone is UTC) and the fraction in nanoseconds. False otherwise."""
    cdef long long y
    cdef int mo, d, hh, mi, ss, zh = 0, zm = 0, nd = 0, a, c
    cdef long long frac = 0
    cdef Py_ssize_t q
    cdef int sign = 0
    if e - p < 19:
        return False
    a, c = _two(b, p), _two(b, p + 2)
    if a < 0 or c < 0 or b[p + 4] != 45 or b[p + 7] != 45:
        return False
    y = a * 100 + c
    mo, d = _two(b, p + 5), _two(b, p + 8)
    if not (b[p + 10] == 84 or b[p + 10] == 116 or b[p + 10] == 32):  # 'T', 't', ' '
        return False
    hh, mi, ss = _two(b, p + 11), _two(b, p + 14), _two(b, p + 17)
    if b[p + 13] != 58 or b[p + 16] != 58:
        return False
    if y < 1 or mo < 1 or mo > 12 or d < 1 or d > _month_days(y, mo) or hh < 0 or hh > 23 or mi < 0 or mi > 59 \
            or ss < 0 or ss > 59:
        return False
    q = p + 19
    if q < e and b[q] == 46:  # '.'
        q += 1
        while q < e and 48 <= b[q] <= 57:
            nd += 1
            if nd > 9:
                return False
            frac = frac * 10 + (b[q] - 48)
            q += 1
        if nd == 0:
            return False
        while nd < 9:
            frac *= 10
            nd += 1
    if q < e:
        if b[q] == 90 or b[q] == 122:  # 'Z', 'z'
            q += 1
        elif b[q] == 43 or b[q] == 45:  # '+', '-'
            sign = 1 if b[q] == 43 else -1
            q += 1
            if e - q < 2:
                return False
            zh = _two(b, q)
            if zh < 0 or zh > 23:
                return False
            q += 2
            if q < e:
                if b[q] == 58:
                    q += 1
                if e - q < 2:
                    return False
                zm = _two(b, q)
                if zm < 0 or zm > 59:
                    return False
                q += 2
    if q != e:
        return False
    sec[0] = _days_from_civil(y, mo, d) * 86400 + hh * 3600 + mi * 60 + ss - sign * (zh * 3600 + zm * 60)
    ns[0] = frac
    return True


cdef bint _strtod_cell(const unsigned char* b, Py_ssize_t p, Py_ssize_t e, double* out) noexcept nogil:
    """A plain decimal off Clinger's fast path (more digits, a large exponent) by the C library's correctly
    rounded strtod: only digits, sign, point and exponent (no nan, inf, hex), finite."""
    cdef char tmp[80]
    cdef char* end
    cdef Py_ssize_t n = e - p, k
    cdef unsigned char ch
    if n <= 0 or n >= 80:
        return False
    for k in range(n):
        ch = b[p + k]
        if not ((48 <= ch <= 57) or ch == 43 or ch == 45 or ch == 46 or ch == 101 or ch == 69):
            return False
        tmp[k] = <char>ch
    tmp[n] = 0
    out[0] = strtod(tmp, &end)
    return end == tmp + n and isfinite(out[0])


cdef Py_ssize_t _rows(const unsigned char* b, Py_ssize_t pos, Py_ssize_t end, bint final, Py_ssize_t max_rows,
                      Py_ssize_t width, unsigned char sep, const int* colmap, int text_col, int iso_col,
                      const double* pow10, double* values, Py_ssize_t stride, int64_t* line_of, int64_t* span,
                      int64_t* isosec, int64_t* isons, Py_ssize_t* r_io, int64_t* line_io, int* state) noexcept nogil:
    """The rows from ``pos`` on into the outputs (see ``parse_rows``); returns the position reached."""
    cdef Py_ssize_t r = r_io[0], le, ce, p, q, cs, cend, c
    cdef int64_t line = line_io[0]
    cdef const unsigned char* nl
    cdef int mc
    cdef unsigned char ch
    cdef bint bad
    state[0] = 0
    while r < max_rows:
        if pos >= end:
            break
        nl = <const unsigned char*>memchr(b + pos, 10, end - pos)
        if nl == NULL:
            if not final:
                break  # an incomplete line: more bytes are needed
            le = end
        else:
            le = nl - b
        ce = le
        if ce > pos and b[ce - 1] == 13:
            ce -= 1
        p = pos
        while p < ce and (b[p] == 32 or b[p] == 9):
            p += 1
        if p == ce:  # blank line
            line += 1
            pos = le + 1 if le < end else end
            continue
        bad = False
        p = pos
        for c in range(width):
            while p < ce and _blank(b[p], sep):
                p += 1
            mc = colmap[c]
            cs = p
            if mc >= 0 and mc != text_col and mc != iso_col:  # a number
                q = decimal_at(b, p, ce, pow10, &values[mc * stride + r])
                if q >= 0:
                    p = q
                    while p < ce and _blank(b[p], sep):
                        p += 1
                    if p < ce and b[p] != sep:
                        q = -1
                if q < 0:  # off the fast path: the whole cell by strtod
                    p = cs
                    while p < ce and b[p] != sep:
                        p += 1
                    cend = p
                    while cend > cs and _blank(b[cend - 1], sep):
                        cend -= 1
                    if not _strtod_cell(b, cs, cend, &values[mc * stride + r]):
                        bad = True
                        break
            else:
                while p < ce and b[p] != sep:
                    if b[p] >= 128:
                        state[0] |= 2  # bytes beyond ASCII: the caller checks the text is UTF-8
                    p += 1
                if mc >= 0:
                    cend = p
                    while cend > cs and _blank(b[cend - 1], sep):
                        cend -= 1
                    if mc == text_col:
                        if cend == cs:
                            bad = True
                            break
                        for q in range(cs, cend):
                            ch = b[q]
                            if ch < 32 or ch == 34 or ch == 39 or ch == 44 or ch == 127:
                                bad = True
                                break
                        if bad:
                            break
                        span[2 * r] = cs
                        span[2 * r + 1] = cend
                    elif not _iso_time(b, cs, cend, &isosec[r], &isons[r]):
                        bad = True
                        break
            if c < width - 1:
                if p >= ce or b[p] != sep:
                    bad = True
                    break
                p += 1
            elif p != ce:
                bad = True
                break
        if bad:
            state[0] |= 1
            break
        line += 1
        line_of[r] = line
        r += 1
        pos = le + 1 if le < end else end
    r_io[0] = r
    line_io[0] = line
    return pos


def parse_rows(buf, Py_ssize_t pos, Py_ssize_t end, bint final, Py_ssize_t max_rows, Py_ssize_t width, int sep,
               colmap, int text_col, int iso_col, pow10, double[:, ::1] values, int64_t[::1] line_of,
               int64_t[:, ::1] span, int64_t[::1] isosec, int64_t[::1] isons, Py_ssize_t r0, long long line0):
    """Rows of a delimited text from bytes ``buf[pos:end]`` into preallocated outputs, from row ``r0``.

    Each line holds ``width`` cells split by the byte ``sep``; ``colmap[c]`` is the output column of
    cell ``c`` (-1: ignored, anything but the separator allowed). Output columns are numbers (a
    decimal: exactly ``float(text)``), except ``text_col`` (a non-empty id without quotes, commas or
    control characters: its trimmed byte span into ``span[r]``) and ``iso_col`` (an ISO 8601 time:
    whole seconds since 1970 UTC into ``isosec[r]``, nanoseconds into ``isons[r]``). ``values`` is
    (columns, max_rows): a column's values are contiguous. Blank lines are skipped (counted in the
    line numbers); blanks around cells are ignored; a line ends in LF or CRLF. ``line_of[r]`` is the
    row's line: ``line0`` + the lines read before it + 1. ``final``: ``end`` is the end of the input
    (a last line without a line break is read), else the rows stop before an incomplete line.

    Returns (rows, pos, line, status): the rows filled so far, the position of the next unread line,
    the line number before it, and status bit 0: that line is off this parser's path (bad, or a
    form only the careful reader takes: it must judge it), bit 1: bytes beyond ASCII were passed
    over in ignored or text cells (the caller checks the text is UTF-8).
    """
    cdef const unsigned char[::1] text = buf
    cdef const int[::1] cm = colmap
    cdef const double[::1] p10 = pow10
    cdef Py_ssize_t r = r0
    cdef int64_t line = line0
    cdef int state = 0
    cdef Py_ssize_t n = text.shape[0]
    if end > n:
        raise ValueError("end beyond the buffer")
    if cm.shape[0] != width or values.shape[1] < max_rows or line_of.shape[0] < max_rows \
            or span.shape[0] < max_rows or isosec.shape[0] < max_rows or isons.shape[0] < max_rows:
        raise ValueError("outputs too small")
    if n == 0 or pos >= end or r >= max_rows:
        return r, pos, line, 0
    cdef const unsigned char* b = &text[0]
    cdef double* v = &values[0, 0]
    cdef Py_ssize_t stride = values.shape[1]
    with nogil:
        pos = _rows(b, pos, end, final, max_rows, width, <unsigned char>sep, &cm[0], text_col, iso_col, &p10[0],
                    v, stride, &line_of[0], &span[0, 0], &isosec[0], &isons[0], &r, &line, &state)
    return r, pos, line, state


def iso_time(bytes text):
    """The kernel's ISO 8601 reading of one cell (for tests and the careful reader): (seconds, ns) or None."""
    cdef int64_t sec = 0, ns = 0
    cdef const unsigned char* b = text
    if _iso_time(b, 0, len(text), &sec, &ns):
        return sec, ns
    return None


cdef inline uint64_t _fnv(const unsigned char* b, Py_ssize_t n) noexcept nogil:
    cdef uint64_t h = 14695981039346656037ULL
    cdef Py_ssize_t k
    for k in range(n):
        h = (h ^ b[k]) * 1099511628211ULL
    return h


cdef class Interner:
    """Byte strings to codes 0, 1, 2, ... in order of first appearance, over any number of calls (an
    open-addressing hash table in C: a code per row without a Python object per row)."""

    cdef int64_t* slot
    cdef Py_ssize_t cap
    cdef uint64_t* hashes
    cdef int64_t* offs
    cdef int64_t* lens
    cdef Py_ssize_t ncode, code_cap
    cdef unsigned char* store
    cdef Py_ssize_t store_len, store_cap

    def __cinit__(self):
        self.cap = 64
        self.slot = <int64_t*>malloc(self.cap * sizeof(int64_t))
        self.code_cap = 16
        self.hashes = <uint64_t*>malloc(self.code_cap * sizeof(uint64_t))
        self.offs = <int64_t*>malloc(self.code_cap * sizeof(int64_t))
        self.lens = <int64_t*>malloc(self.code_cap * sizeof(int64_t))
        self.store_cap = 256
        self.store = <unsigned char*>malloc(self.store_cap)
        if not (self.slot and self.hashes and self.offs and self.lens and self.store):
            raise MemoryError()
        for k in range(self.cap):
            self.slot[k] = -1
        self.ncode = 0
        self.store_len = 0

    def __dealloc__(self):
        free(self.slot)
        free(self.hashes)
        free(self.offs)
        free(self.lens)
        free(self.store)

    def __len__(self):
        return self.ncode

    def name(self, Py_ssize_t code) -> bytes:
        if not 0 <= code < self.ncode:
            raise IndexError(code)
        return (<char*>self.store)[self.offs[code]:self.offs[code] + self.lens[code]]

    cdef int _grow_table(self) noexcept nogil:
        cdef Py_ssize_t cap = self.cap * 2, k, i
        cdef int64_t* slot = <int64_t*>malloc(cap * sizeof(int64_t))
        if slot == NULL:
            return -1
        for k in range(cap):
            slot[k] = -1
        for k in range(self.ncode):
            i = <Py_ssize_t>(self.hashes[k] & <uint64_t>(cap - 1))
            while slot[i] >= 0:
                i = (i + 1) & (cap - 1)
            slot[i] = k
        free(self.slot)
        self.slot = slot
        self.cap = cap
        return 0

    cdef int64_t _code(self, const unsigned char* b, Py_ssize_t n) noexcept nogil:
        """The code of b[:n], added if new; -1 when out of memory."""
        cdef uint64_t h = _fnv(b, n)
        cdef Py_ssize_t i = <Py_ssize_t>(h & <uint64_t>(self.cap - 1))
        cdef int64_t k
        cdef void* grown
        while True:
            k = self.slot[i]
            if k < 0:
                break
            if self.hashes[k] == h and self.lens[k] == n and memcmp(self.store + self.offs[k], b, n) == 0:
                return k
            i = (i + 1) & (self.cap - 1)
        if self.ncode == self.code_cap:
            self.code_cap *= 2
            grown = realloc(self.hashes, self.code_cap * sizeof(uint64_t))
            if grown == NULL:
                return -1
            self.hashes = <uint64_t*>grown
            grown = realloc(self.offs, self.code_cap * sizeof(int64_t))
            if grown == NULL:
                return -1
            self.offs = <int64_t*>grown
            grown = realloc(self.lens, self.code_cap * sizeof(int64_t))
            if grown == NULL:
                return -1
            self.lens = <int64_t*>grown
        while self.store_len + n > self.store_cap:
            self.store_cap *= 2
            grown = realloc(self.store, self.store_cap)
            if grown == NULL:
                return -1
            self.store = <unsigned char*>grown
        k = self.ncode
        memcpy(self.store + self.store_len, b, n)
        self.hashes[k] = h
        self.offs[k] = self.store_len
        self.lens[k] = n
        self.store_len += n
        self.ncode += 1
        self.slot[i] = k
        if 2 * self.ncode > self.cap and self._grow_table() < 0:
            return -1
        return k

    def codes(self, buf, int64_t[:, ::1] span, Py_ssize_t rows):
        """Codes (rows,) int64 of the byte strings ``buf[span[r, 0]:span[r, 1]]``; returns (codes, first new
        code, (new codes,) int64 the row where each new code first appears)."""
        cdef const unsigned char[::1] text = buf
        cdef Py_ssize_t first = self.ncode, r, n = text.shape[0], before
        cdef int64_t k
        cdef bint failed = False
        if span.shape[0] < rows:
            raise ValueError("span too short")
        for r in range(rows):
            if not (0 <= span[r, 0] <= span[r, 1] <= n):
                raise ValueError("span outside the buffer")
        cdef cnp.ndarray out = np.empty(rows, np.int64)
        cdef cnp.ndarray first_row = np.empty(rows, np.int64)
        cdef int64_t* o = <int64_t*>cnp.PyArray_DATA(out)
        cdef int64_t* fr = <int64_t*>cnp.PyArray_DATA(first_row)
        cdef const unsigned char* b = &text[0] if n > 0 else NULL
        with nogil:
            for r in range(rows):
                before = self.ncode
                k = self._code(b + span[r, 0], span[r, 1] - span[r, 0])
                if k < 0:
                    failed = True
                    break
                o[r] = k
                if self.ncode > before:
                    fr[k - first] = r
        if failed:
            raise MemoryError()
        return out, first, first_row[:self.ncode - first].copy()


def entity_order(const int64_t[::1] codes, const double[::1] t, const int64_t[::1] lines, double[::1] last_t,
                 int64_t[::1] last_line, unsigned char[::1] seen, unsigned char[::1] piece_start):
    """Each entity's time never decreasing, over calls: ``last_t``, ``last_line`` and ``seen`` (by code,
    as long as the codes) carry each entity's last row. Marks ``piece_start[r]`` where an entity's
    first row is. Returns the first row whose time goes back (its entity's state left at the row
    before), or -1."""
    cdef Py_ssize_t n = codes.shape[0], r
    cdef int64_t k
    cdef Py_ssize_t bad = -1
    cdef Py_ssize_t m = last_t.shape[0]
    if t.shape[0] < n or lines.shape[0] < n or piece_start.shape[0] < n or last_line.shape[0] < m \
            or seen.shape[0] < m:
        raise ValueError("inputs too short")
    for r in range(n):
        if not 0 <= codes[r] < m:
            raise ValueError("code beyond the tables")
    with nogil:
        for r in range(n):
            k = codes[r]
            if seen[k]:
                piece_start[r] = 0
                if t[r] < last_t[k]:
                    bad = r
                    break
            else:
                piece_start[r] = 1
                seen[k] = 1
            last_t[k] = t[r]
            last_line[k] = lines[r]
    return bad


def carry(const int64_t[::1] codes, double[::1] values, double[::1] last):
    """In place: each NaN value becomes its entity's last value before it (``last[code]`` before the first of
    these rows), and ``last`` each entity's last value after them."""
    cdef Py_ssize_t n = codes.shape[0], r, m = last.shape[0]
    cdef int64_t k
    if values.shape[0] < n:
        raise ValueError("values too short")
    for r in range(n):
        if not 0 <= codes[r] < m:
            raise ValueError("code beyond the table")
    with nogil:
        for r in range(n):
            k = codes[r]
            if values[r] != values[r]:  # NaN
                values[r] = last[k]
            else:
                last[k] = values[r]
