# The compiled plain-OBJ reader (obj.py says what it reads and returns): one counting pass, one
# filling pass, both without the GIL and without a Python object per line; any line off the
# plain shape declines the whole file (None), and the Python readers decide.

import numpy as np

cimport numpy as cnp
from libc.string cimport memchr, memcmp

from tankcd_cli.io._decimal cimport decimal_at as _number, is_blank as _is_blank, is_digit as _is_digit

cnp.import_array()


cdef inline Py_ssize_t _index(const unsigned char* buf, Py_ssize_t pos, Py_ssize_t end, bint slash,
                              long long* out) noexcept nogil:
    """One face index ``i``, ``i/j``, ``i//k`` or ``i/j/k`` at ``pos`` (``i`` digits only, >= 1; what
    follows the first '/' is not read, only skipped, and only when ``slash``); the position after
    it, or -1."""
    cdef long long value = 0
    cdef int digits = 0
    while pos < end and _is_digit(buf[pos]):
        value = value * 10 + (buf[pos] - 48)
        digits += 1
        if digits > 18:
            return -1
        pos += 1
    if digits == 0 or value == 0:
        return -1
    if pos < end and buf[pos] == 47:  # '/'
        if not slash:
            return -1
        while pos < end and 32 < buf[pos] < 128:
            pos += 1
    out[0] = value
    return pos


cdef bint _plain_text(const unsigned char* buf, Py_ssize_t pos, Py_ssize_t end) noexcept nogil:
    """Whether the text of an ignored line (a comment, a name, ...) is valid UTF-8 (as strictly as
    Python decodes) with no character Python's ``str.splitlines`` breaks a line at."""
    cdef unsigned char c, b1, b2, lo, hi
    while pos < end:
        c = buf[pos]
        if c < 128:
            # '\r' (alone: the line end was cut off), '\v', '\f', '\x1c', '\x1d', '\x1e'
            if c == 13 or c == 11 or c == 12 or c == 28 or c == 29 or c == 30:
                return False
            pos += 1
        elif 0xC2 <= c <= 0xDF:
            if pos + 1 >= end or not (0x80 <= buf[pos + 1] <= 0xBF):
                return False
            if c == 0xC2 and buf[pos + 1] == 0x85:  # U+0085, a line break to splitlines
                return False
            pos += 2
        elif 0xE0 <= c <= 0xEF:
            if pos + 2 >= end:
                return False
            b1 = buf[pos + 1]
            b2 = buf[pos + 2]
            lo = 0xA0 if c == 0xE0 else 0x80  # no overlong forms
            hi = 0x9F if c == 0xED else 0xBF  # no surrogates
            if not (lo <= b1 <= hi) or not (0x80 <= b2 <= 0xBF):
                return False
            if c == 0xE2 and b1 == 0x80 and (b2 == 0xA8 or b2 == 0xA9):  # U+2028, U+2029
                return False
            pos += 3
        elif 0xF0 <= c <= 0xF4:
            if pos + 3 >= end:
                return False
            b1 = buf[pos + 1]
            lo = 0x90 if c == 0xF0 else 0x80
            hi = 0x8F if c == 0xF4 else 0xBF  # nothing past U+10FFFF
            if not (lo <= b1 <= hi) or not (0x80 <= buf[pos + 2] <= 0xBF) or not (0x80 <= buf[pos + 3] <= 0xBF):
                return False
            pos += 4
        else:
            return False
    return True


cdef void _count(const unsigned char* buf, Py_ssize_t n, Py_ssize_t* nv, Py_ssize_t* nf,
                 Py_ssize_t* nm) noexcept nogil:
    """Lines starting "v ", "f ", and "o " or "g " (the sizes of the outputs)."""
    cdef Py_ssize_t pos = 0
    cdef const unsigned char* nl
    cdef unsigned char c
    nv[0] = nf[0] = nm[0] = 0
    while pos < n:
        if pos + 1 < n and buf[pos + 1] == 32:
            c = buf[pos]
            if c == 118:  # 'v'
                nv[0] += 1
            elif c == 102:  # 'f'
                nf[0] += 1
            elif c == 111 or c == 103:  # 'o', 'g'
                nm[0] += 1
        nl = <const unsigned char*>memchr(buf + pos, 10, n - pos)
        if nl == NULL:
            break
        pos = (nl - buf) + 1


cdef struct _Fill:
    double* vertices
    long long* faces
    unsigned char* mark_kind
    long long* mark_faces
    long long* mark_start
    long long* mark_end
    Py_ssize_t nv, nf, nm  # capacities
    Py_ssize_t iv, jf, im  # filled
    long long n_lines, n_points, max_index


cdef bint _fill(const unsigned char* buf, Py_ssize_t n, const double* pow10, _Fill* s) noexcept nogil:
    """Every line of the file into ``s``; False (decline) at the first line off the plain shape."""
    cdef Py_ssize_t p = 0, e, ce, pos, k
    cdef const unsigned char* nl
    cdef unsigned char c0, c1
    cdef int slash = -1  # faces with '/': decided by the first face line, as simple_obj does
    cdef long long idx
    while p < n:
        nl = <const unsigned char*>memchr(buf + p, 10, n - p)
        e = n if nl == NULL else (nl - buf)
        ce = e
        if nl != NULL and ce > p and buf[ce - 1] == 13:  # CRLF
            ce -= 1
        if ce == p:
            p = e + 1
            continue
        if buf[ce - 1] == 92:  # a continuation line ('\\' last): the full reader joins them
            return False
        c0 = buf[p]
        c1 = buf[p + 1] if ce - p >= 2 else 0
        if c0 == 118 and c1 == 32:  # "v "
            if s.iv >= s.nv:
                return False
            pos = p + 2
            for k in range(3):
                while pos < ce and _is_blank(buf[pos]):
                    pos += 1
                pos = _number(buf, pos, ce, pow10, s.vertices + 3 * s.iv + k)
                if pos < 0 or (pos < ce and not _is_blank(buf[pos])):
                    return False
            while pos < ce and _is_blank(buf[pos]):
                pos += 1
            if pos != ce:  # a fourth token: colours, a weight
                return False
            s.iv += 1
        elif c0 == 102 and c1 == 32:  # "f "
            if s.jf >= s.nf:
                return False
            if slash < 0:
                slash = memchr(buf + p, 47, ce - p) != NULL
            pos = p + 2
            for k in range(3):
                while pos < ce and _is_blank(buf[pos]):
                    pos += 1
                pos = _index(buf, pos, ce, slash, &idx)
                if pos < 0 or (pos < ce and not _is_blank(buf[pos])):
                    return False
                if idx > s.max_index:
                    s.max_index = idx
                s.faces[3 * s.jf + k] = idx - 1
            while pos < ce and _is_blank(buf[pos]):
                pos += 1
            if pos != ce:  # a polygon
                return False
            s.jf += 1
        elif (c0 == 111 or c0 == 103) and c1 == 32:  # "o NAME", "g NAME"
            if s.im >= s.nm or not _plain_text(buf, p + 2, ce):
                return False
            s.mark_kind[s.im] = c0
            s.mark_faces[s.im] = s.jf
            s.mark_start[s.im] = p + 2
            s.mark_end[s.im] = ce
            s.im += 1
        elif (c0 == 108 or c0 == 112) and c1 == 32:  # "l ", "p "
            if not _plain_text(buf, p, ce):
                return False
            if c0 == 108:
                s.n_lines += 1
            else:
                s.n_points += 1
        elif (c0 == 35  # '#'
              or (c0 == 118 and (c1 == 116 or c1 == 110 or c1 == 112))  # "vt", "vn", "vp"
              or (c0 == 115 and c1 == 32)  # "s "
              or (ce - p >= 6 and (memcmp(buf + p, b"usemtl", 6) == 0 or memcmp(buf + p, b"mtllib", 6) == 0))):
            if not _plain_text(buf, p, ce):
                return False
        else:  # blanks only, or a line the Python readers must judge
            for pos in range(p, ce):
                if not _is_blank(buf[pos]):
                    return False
        p = e + 1
    return True


def scan_obj(data, pow10):
    """A plain OBJ's vertices, triangles, ``l``/``p`` counts and ``o``/``g`` marks, or None.

    data : bytes (or any contiguous uint8 buffer) of the file, without a byte-order mark
    pow10 : (23,) float64 with pow10[k] == 10.0 ** k
    Returns None (declined) or (vertices (n, 3) float64, faces (m, 3) int64 zero-based,
    n_lines, n_points, mark_kind (k,) uint8 b'o'/b'g', mark_faces (k,) int64 faces before the
    mark, mark_start, mark_end (k,) int64 byte range of the mark's name, "o "/"g " excluded).
    """
    cdef const unsigned char[::1] text
    cdef const double[::1] p10
    try:
        text = data
    except (TypeError, ValueError):
        text = np.ascontiguousarray(data, dtype=np.uint8)
    try:
        p10 = pow10
    except (TypeError, ValueError):
        p10 = np.ascontiguousarray(pow10, dtype=np.float64)
    if p10.shape[0] < 23:
        raise ValueError("pow10 needs 10**0 .. 10**22")
    cdef Py_ssize_t n = text.shape[0], nv, nf, nm
    if n == 0:
        return None
    cdef const unsigned char* b = &text[0]
    with nogil:
        _count(b, n, &nv, &nf, &nm)
    if nv == 0 or nf == 0:
        return None
    cdef cnp.ndarray vertices = np.empty((nv, 3), dtype=np.float64)
    cdef cnp.ndarray faces = np.empty((nf, 3), dtype=np.int64)
    cdef cnp.ndarray mark_kind = np.empty(nm, dtype=np.uint8)
    cdef cnp.ndarray mark_faces = np.empty(nm, dtype=np.int64)
    cdef cnp.ndarray mark_start = np.empty(nm, dtype=np.int64)
    cdef cnp.ndarray mark_end = np.empty(nm, dtype=np.int64)
    cdef _Fill s
    s.vertices = <double*>cnp.PyArray_DATA(vertices)
    s.faces = <long long*>cnp.PyArray_DATA(faces)
    s.mark_kind = <unsigned char*>cnp.PyArray_DATA(mark_kind)
    s.mark_faces = <long long*>cnp.PyArray_DATA(mark_faces)
    s.mark_start = <long long*>cnp.PyArray_DATA(mark_start)
    s.mark_end = <long long*>cnp.PyArray_DATA(mark_end)
    s.nv, s.nf, s.nm = nv, nf, nm
    s.iv = s.jf = s.im = 0
    s.n_lines = s.n_points = s.max_index = 0
    cdef bint ok
    cdef const double* p = &p10[0]
    with nogil:
        ok = _fill(b, n, p, &s)
    if not ok or s.iv != nv or s.jf != nf or s.im != nm or s.max_index > nv:
        return None
    return vertices, faces, int(s.n_lines), int(s.n_points), mark_kind, mark_faces, mark_start, mark_end
