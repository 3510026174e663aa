"""Numeric CSV columns by header name, read in chunks with every bad cell named by line and column."""

from __future__ import annotations

import itertools
from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.csv_kernels import POW10, parse_table


def numeric_chunks(fh, name: str, required: tuple, optional: tuple, chunk_rows: int,
                   blank_ok: tuple = (), line_offset: int | None = None,
                   hint=None) -> Iterator[tuple[list, list, np.ndarray]]:
    """Yield (line numbers, column names, values (rows, cols)) chunk by chunk.

    Header row required, column order free, extra columns ignored. Columns in
    ``blank_ok`` may be empty (NaN); every other cell must be a finite number.
    ``line_offset``: the file line before the first data line given (for a part of a file
    read after its header), so that errors name the line of the whole file.
    ``hint(header, missing)``: a sentence to add when required columns are missing (or "").
    """
    header_line = fh.readline()
    lineno = 1
    while header_line and not header_line.strip():
        header_line = fh.readline()
        lineno += 1
    if not header_line:
        raise InputError(name, f"file is empty (a header row with {','.join(required)} is needed)")
    if "\x00" in header_line:
        raise InputError(name, "not a text file", where="line 1")
    header = [h.strip().strip('"').strip() for h in header_line.rstrip("\r\n").split(",")]
    missing = [c for c in required if c not in header]
    if missing:
        extra = hint(header, missing) if hint is not None else ""
        raise InputError(name, f"header lacks the required column{'s' if len(missing) > 1 else ''} "
                               f"{', '.join(missing)} (found: {', '.join(header)[:200]})" + (f"; {extra}" if extra else ""),
                         where=f"line {lineno}")
    dup = sorted({h for h in header if header.count(h) > 1 and h in required + optional})
    if dup:
        raise InputError(name, f"column {dup[0]} appears twice in the header", where=f"line {lineno}")
    if line_offset is not None:
        lineno = line_offset
    wanted = list(required) + [c for c in optional if c in header]
    cols = [header.index(c) for c in wanted]
    width = len(header)
    blank_cols = [j for j, c in enumerate(wanted) if c in blank_ok]
    while True:
        lines = list(itertools.islice(fh, chunk_rows))
        if not lines:
            return
        start_line = lineno + 1
        lineno += len(lines)
        values = _well_formed_values(lines, width, cols)
        if values is not None:
            yield list(range(start_line, start_line + len(lines))), wanted, values
            continue
        rows, cells = [], []
        error = None
        for k, line in enumerate(lines):
            body = line.rstrip("\r\n")
            if not body.strip():
                continue
            parts = body.split(",")
            if len(parts) != width:
                error = InputError(name, f"expected {width} columns as in the header, found {len(parts)}",
                                   where=f"line {start_line + k}")
                break
            rows.append(start_line + k)
            cells.append([parts[i] for i in cols])
        blank = np.zeros((len(cells), len(wanted)), dtype=bool)  # empty cells (allowed in blank_ok columns)
        if blank_cols:
            for r, row in enumerate(cells):
                for j in blank_cols:
                    if not row[j].strip():
                        row[j] = "nan"
                        blank[r, j] = True
        values = None
        if cells:
            try:
                values = np.array(cells, dtype=np.float64)
            except ValueError:
                values = None
            if values is None or not np.isfinite(values[~blank]).all():
                bad, bad_error = _first_bad(cells, rows, wanted, name, blank)
                error = bad_error
                rows, cells = rows[:bad], cells[:bad]
                values = np.array(cells, dtype=np.float64).reshape(len(cells), len(wanted))
        # the rows before a bad one are still delivered (and written) before the error stops the run
        if values is not None and len(rows):
            yield rows, wanted, values
        if error is not None:
            raise error


def _well_formed_values(lines: list, width: int, cols: list):
    """The chunk's wanted columns (rows, len(cols)) parsed in one compiled or C call, or None.

    Only for the common case: every line has exactly ``width`` cells, all finite
    numbers. Anything else (blank lines or cells, text, NaN) returns None and is
    read cell by cell, which names the first bad line and column.
    """
    text = "".join(lines)
    if text.isascii():
        values, ok = parse_table(np.frombuffer(text.encode("ascii"), np.uint8), len(lines), width, POW10)
        if ok:
            return np.ascontiguousarray(values[:, cols])
    commas = width - 1
    if any(line.count(",") != commas for line in lines):
        return None
    if "\r" in text:
        text = text.replace("\r\n", "\n")
        if "\r" in text:  # a stray carriage return inside a line: let the careful path judge it
            return None
    try:
        flat = np.fromstring(text.replace("\n", ","), sep=",")
    except ValueError:
        return None
    if flat.size != len(lines) * width:
        return None
    values = flat.reshape(len(lines), width)[:, cols]
    if not np.isfinite(values).all():
        return None
    return np.ascontiguousarray(values)


def _first_bad(cells, rows, wanted, name, blank):
    """Index of the first bad row and the error naming its line and column (blank: (rows, cols) empty cells)."""
    for k, row in enumerate(cells):
        for j, text in enumerate(row):
            if blank[k, j]:
                continue
            try:
                value = float(text)
            except ValueError:
                return k, InputError(name, f"not a number: {text.strip()[:40]!r}", where=f"line {rows[k]} column {wanted[j]}")
            if not np.isfinite(value):
                return k, InputError(name, f"non-finite value {text.strip()!r}", where=f"line {rows[k]} column {wanted[j]}")
    return len(cells), InputError(name, "unparseable rows")  # pragma: no cover
