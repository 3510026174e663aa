"""A compiled parser for the common shape of a numeric CSV chunk (numba).

Exactly the value ``float(text)`` gives, by Clinger's fast path: a decimal
with at most 15 significant digits and a power of ten within 10^+-22 is one
correctly rounded multiplication or division of two exact doubles. Anything
else (more digits, large exponents, nan/inf, quotes, empty cells, a wrong cell
count) makes the whole chunk fall back to the general readers, which also
name the bad line and column.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_POW10 = np.array([10.0 ** k for k in range(23)])


@njit(cache=True)
def parse_table(buf, rows, width, pow10):  # pragma: no cover - compiled
    """Parse ``rows`` lines of ``width`` comma-separated decimals from bytes; returns (values, ok)."""
    out = np.empty((rows, width))
    n = buf.shape[0]
    pos = 0
    for r in range(rows):
        for c in range(width):
            while pos < n and (buf[pos] == 32 or buf[pos] == 9):
                pos += 1
            negative = False
            if pos < n and (buf[pos] == 45 or buf[pos] == 43):
                negative = buf[pos] == 45
                pos += 1
            mant = 0
            digits = 0  # significant digits kept in mant
            scale = 0  # decimal exponent of mant's last digit
            seen = False
            while pos < n and 48 <= buf[pos] <= 57:
                seen = True
                if mant != 0 or buf[pos] != 48:
                    mant = mant * 10 + (buf[pos] - 48)
                    digits += 1
                pos += 1
            if pos < n and buf[pos] == 46:
                pos += 1
                while pos < n and 48 <= buf[pos] <= 57:
                    seen = True
                    if mant != 0 or buf[pos] != 48:
                        mant = mant * 10 + (buf[pos] - 48)
                        digits += 1
                    scale -= 1
                    pos += 1
            if not seen or digits > 15:
                return out, False
            if pos < n and (buf[pos] == 101 or buf[pos] == 69):
                pos += 1
                eneg = False
                if pos < n and (buf[pos] == 45 or buf[pos] == 43):
                    eneg = buf[pos] == 45
                    pos += 1
                e = 0
                eseen = False
                while pos < n and 48 <= buf[pos] <= 57:
                    eseen = True
                    e = e * 10 + (buf[pos] - 48)
                    if e > 400:
                        return out, False
                    pos += 1
                if not eseen:
                    return out, False
                scale += -e if eneg else e
            while pos < n and (buf[pos] == 32 or buf[pos] == 9):
                pos += 1
            if scale < -22 or scale > 22:
                if mant != 0:
                    return out, False
                scale = 0
            value = float(mant)
            value = value * pow10[scale] if scale >= 0 else value / pow10[-scale]
            out[r, c] = -value if negative else value
            # the separator: a comma between cells, a line end after the last
            if c < width - 1:
                if pos >= n or buf[pos] != 44:
                    return out, False
                pos += 1
            else:
                if pos < n and buf[pos] == 13:
                    pos += 1
                if pos < n:
                    if buf[pos] != 10:
                        return out, False
                    pos += 1
                elif r != rows - 1:
                    return out, False
    return out, pos == n
