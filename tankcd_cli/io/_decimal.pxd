# The decimal parser shared by the compiled text readers (_csv_kernels.pyx, _obj.pyx), inlined
# where cimported: Clinger's fast path, the exact value float() gives, or "not on the fast path".

cdef inline bint is_blank(unsigned char ch) noexcept nogil:
    return ch == 32 or ch == 9  # ' ', '\t'


cdef inline bint is_digit(unsigned char ch) noexcept nogil:
    return 48 <= ch <= 57


cdef inline Py_ssize_t decimal_at(const unsigned char* buf, Py_ssize_t pos, Py_ssize_t end,
                               const double* pow10, double* out) noexcept nogil:
    """One decimal at ``pos`` (no leading blanks) into ``out`` by Clinger's fast path, exactly
    ``float(text)``: at most 15 significant digits and a power of ten within 10^+-22 make one
    correctly rounded multiplication or division of two exact doubles (pow10[k] == 10.0 ** k,
    k <= 22). The position after it, or -1 when it is off the fast path or no number."""
    cdef unsigned long long mant = 0  # unsigned: wraps (no C overflow) past 19 digits, which fail anyway
    cdef long long e, scale = 0
    cdef int digits = 0  # significant digits kept in mant
    cdef bint negative = False, seen = False, eneg, eseen
    cdef double value
    if pos < end and (buf[pos] == 45 or buf[pos] == 43):  # '-', '+'
        negative = buf[pos] == 45
        pos += 1
    while pos < end and is_digit(buf[pos]):
        seen = True
        mant = mant * 10 + (buf[pos] - 48)
        digits += mant != 0  # leading zeros are not significant
        pos += 1
    if pos < end and buf[pos] == 46:  # '.'
        pos += 1
        while pos < end and is_digit(buf[pos]):
            seen = True
            mant = mant * 10 + (buf[pos] - 48)
            digits += mant != 0
            scale -= 1
            pos += 1
    if not seen or digits > 15:
        return -1
    if pos < end and (buf[pos] == 101 or buf[pos] == 69):  # 'e', 'E'
        pos += 1
        eneg = False
        if pos < end and (buf[pos] == 45 or buf[pos] == 43):
            eneg = buf[pos] == 45
            pos += 1
        e = 0
        eseen = False
        while pos < end and is_digit(buf[pos]):
            eseen = True
            e = e * 10 + (buf[pos] - 48)
            if e > 400:
                return -1
            pos += 1
        if not eseen:
            return -1
        scale += -e if eneg else e
    if scale < -22 or scale > 22:
        if mant != 0:
            return -1
        scale = 0
    value = <double><long long>mant  # at most 15 digits: exact
    if scale >= 0:
        value = value * pow10[scale]
    else:
        value = value / pow10[-scale]
    out[0] = -value if negative else value
    return pos
