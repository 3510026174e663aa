"""Fixed-point CSV text for a table of numbers and short labels, compiled ahead of time (Cython).

Python's ``%`` formatting costs about 4 us a pose row (most of a replay's
per-row time); this writes the same text at a few tens of nanoseconds a cell.
A number is rounded to its column's decimals from ``value * 10**decimals``
(``rint``), so where printf's correctly rounded text lies exactly on a tie it
can differ in the last digit; callers send values whose scaled magnitude is
below 2**53 (else they format in Python). Non-finite cells are left empty.
Labels are any text: written as UTF-8 (the kernel copies their bytes), the result decoded as
ASCII when every label is (the common case: no second pass) and as UTF-8 otherwise.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.io._fixed_text import format_table  # noqa: F401


def table_text(numbers: np.ndarray, decimals: np.ndarray, codes: np.ndarray, labels: list, kinds: np.ndarray,
               index: np.ndarray, row_ends: np.ndarray | None = None) -> str | None:
    """CSV text of the rows (see ``format_table``), or None when a value is too large for fixed point.
    ``row_ends``: an (N,) int64 array that gets each row's end in the text (its newline's index + 1,
    counted in characters of the returned string, which are bytes only while the labels are ASCII)."""
    numbers = np.ascontiguousarray(numbers, dtype=np.float64)
    decimals = np.asarray(decimals, dtype=np.int64)
    with np.errstate(invalid="ignore", over="ignore"):
        scaled = np.abs(numbers) * (10.0 ** decimals)
    # a finite value whose scaled magnitude overflows to inf is too large as well
    if np.any(np.isfinite(numbers) & ~(scaled < 2.0 ** 53)):
        return None
    encoded = [s.encode("utf-8") for s in labels]
    ascii_only = all(len(e) == len(s) for e, s in zip(encoded, labels))
    width = max([len(e) for e in encoded] + [1])
    table = np.zeros((len(encoded), width), np.uint8)
    for k, e in enumerate(encoded):
        table[k, :len(e)] = np.frombuffer(e, np.uint8)
    lengths = np.array([len(e) for e in encoded], np.int64)
    n = numbers.shape[0]
    # per cell at most sign + 16 integer digits + point + decimals, plus the separator
    per_row = int(np.sum(np.where(kinds == 0, 19 + decimals[np.minimum(index, len(decimals) - 1)], width + 1))) + 1
    out = np.empty(max(n * per_row, 1), np.uint8)
    # row blocks formatted in parallel, each at its row's bound (the same bytes as one pass)
    used = format_table(numbers, decimals, np.ascontiguousarray(codes, dtype=np.int64), table, lengths,
                        np.asarray(kinds, np.int64), np.asarray(index, np.int64), out, per_row, row_ends)
    if ascii_only:
        return str(memoryview(out)[:used], "ascii")  # decoded straight from the buffer (no bytes copy)
    if row_ends is not None and n:
        # byte offsets to character offsets: less the UTF-8 continuation bytes (10xxxxxx) before each end
        continuation = np.cumsum((out[:used] & 0xC0) == 0x80)
        row_ends[:n] -= continuation[row_ends[:n] - 1]
    return str(memoryview(out)[:used], "utf-8")
