"""The trajectory CSV reader's core: the header, the separator, and the rows as chunks (docs/formats.md).

The file is read as bytes in blocks; a compiled pass (``_csv_kernels.parse_rows``) turns whole
lines into columns (numbers exactly as ``float`` reads them, the entity ids as byte spans, ISO
8601 times as seconds and nanoseconds) and stops at the first line off its path; that one line is
judged here in Python (``_careful``), which either reads it (a form only Python takes) or names
what is wrong with it (the line and the column). Memory holds one chunk of rows and its bytes.

The rules (each refusal one line naming the file and the line):

- before the header: blank lines and lines starting with ``#`` (comments) are skipped;
- the header: names in any case, with blanks around them, optionally in double quotes;
- the separator: the one of ``,`` ``;`` tab the header holds; where it holds several, the one
  splitting it into the required columns (refused where none or more than one does); a header
  with none of them is refused;
- ``t``: numbers (seconds), or ISO 8601 times (seconds from the file's first row), decided by the
  first row; a mix is refused; ``unix_time`` in its place: seconds since 1970-01-01T00:00:00Z (t
  counts from the first row); a comment ``# time_origin: <ISO 8601 time>`` before the header names
  the instant t counts from (numbers as they are, ISO and ``unix_time`` times counted from it);
- ``x``, ``y`` or ``lon``, ``lat`` (``x``, ``y`` win where both are there); the heading ``yaw_deg``
  or, with ``lon``, ``lat``, ``heading_deg`` (a compass bearing from true north), or with ``lon``,
  ``lat`` none (``heading`` is None: the reader takes it from the track);
- ``entity``: an id without quotes, commas or control characters (blanks around it ignored);
- numbers: a point as the decimal mark (a decimal comma is refused, naming the fix).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import datetime
from decimal import Decimal

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.csv_kernels import POW10, Interner, parse_rows
from tankcd_cli.io.trajectory.names import entity_id_fault

SEPARATORS = (",", ";", "\t")
SEP_NAMES = {",": "a comma", ";": "a semicolon", "\t": "a tab"}
OPTIONAL = ("turret_deg", "gun_deg")
KNOWN = ("t", "unix_time", "x", "y", "lon", "lat", "yaw_deg", "heading_deg", "turret_deg", "gun_deg", "entity")
EPOCH_COLUMN = "unix_time"  # t as seconds since 1970-01-01T00:00:00Z
_ORIGIN = re.compile(rb"\s*#\s*time_origin\s*:\s*(.*?)\s*", re.IGNORECASE)
BLOCK = 1 << 22  # bytes read at a time
NOT_UTF8 = "not UTF-8 text (a trajectory is a CSV file)"
_ISO = re.compile(rb"(\d{4})-(\d\d)-(\d\d)[Tt ](\d\d):(\d\d):(\d\d)(?:\.(\d{1,9}))?(?:([Zz])|([+-])(\d\d)(?::?(\d\d))?)?")
_ISO_START = re.compile(rb"\s*\d{4}-\d\d-\d\d")
_EPOCH_ORDINAL = 719163  # date(1970, 1, 1).toordinal()


def iso_seconds(text: bytes):
    """An ISO 8601 time as this reader takes it (``YYYY-MM-DD``, ``T`` or a space, ``hh:mm:ss``, an optional
    fraction of 1-9 digits, an optional zone ``Z`` or ``+hh:mm``, ``+hhmm``, ``+hh``; no zone is UTC) ->
    (whole seconds since 1970 UTC, nanoseconds), or None. The compiled reader's rule, in Python."""
    m = _ISO.fullmatch(text)
    if m is None:
        return None
    y, mo, d, hh, mi, ss = (int(g) for g in m.groups()[:6])
    try:
        day = datetime(y, mo, d, hh, mi, ss).date().toordinal() - _EPOCH_ORDINAL
    except ValueError:
        return None
    offset = 0
    if m.group(9):
        zh, zm = int(m.group(10)), int(m.group(11) or 0)
        if zh > 23 or zm > 59:
            return None
        offset = (1 if m.group(9) == b"+" else -1) * (zh * 3600 + zm * 60)
    ns = int(m.group(7).ljust(9, b"0")) if m.group(7) else 0
    return day * 86400 + hh * 3600 + mi * 60 + ss - offset, ns


def epoch_seconds(seconds: int, ns: int) -> float:
    """(whole seconds since 1970, nanoseconds) -> the float64 nearest to their exact sum (the decimal
    ``utc_text`` writes is read back into the float it came from)."""
    return float(Decimal(int(seconds)) + Decimal(int(ns)).scaleb(-9))


@dataclass
class Layout:
    """What the header of a trajectory CSV says, and what the first row decided."""

    name: str
    sep: str
    header: list
    header_line: int  # the header's line number
    body_start: int  # byte offset of the line after the header
    width: int
    columns: list  # output columns, in order: t|unix_time, x|lon, y|lat, yaw_deg|heading_deg, [turret_deg], [gun_deg]
    colmap: np.ndarray  # (width,) int32: the output column of each cell (entity: len(columns)), or -1
    geographic: bool
    heading: str | None  # "yaw_deg" or "heading_deg"; None: lon, lat without one (from the track)
    entity: bool
    has_turret: bool
    comment_lines: int = 0
    iso: bool | None = None  # t as ISO 8601 times (None: not known before the first row)
    t0: tuple = (0, 0)  # the first row's time (s since 1970, ns) where iso
    blank_lines: int = 0
    origin: tuple | None = None  # a ``# time_origin:`` comment's instant (s since 1970, ns)
    epoch: bool = False  # t is the unix_time column: seconds since 1970
    base: float | None = None  # where epoch: the value t counts from (the origin's, or the first row's)

    @property
    def time_origin(self) -> float | None:
        """The UTC instant of t = 0 as seconds since 1970 (None: t is relative): the ``time_origin``
        comment's, else the first row's where t is an absolute time (ISO 8601, ``unix_time``)."""
        if self.origin is not None:
            return epoch_seconds(*self.origin)
        if self.iso:
            return epoch_seconds(*self.t0)
        if self.epoch:
            return self.base
        return None

    @property
    def text_col(self) -> int:
        return len(self.columns) if self.entity else -1


def read_layout(fh, name: str, geographic_ok: bool = True) -> Layout:
    """Read the lines before the header and the header from a binary stream (left after the header)."""
    offset = lineno = comments = 0
    header = None
    origin = None
    while True:
        raw = fh.readline()
        if not raw:
            break
        lineno += 1
        offset += len(raw)
        line = raw[3:] if lineno == 1 and raw.startswith(b"\xef\xbb\xbf") else raw
        if not line.strip():
            continue
        if line.lstrip().startswith(b"#"):
            comments += 1
            m = _ORIGIN.fullmatch(line.rstrip(b"\r\n"))
            if m is not None:
                got = iso_seconds(m.group(1))
                if got is None:
                    raise InputError(name, f"time_origin {m.group(1).decode(errors='replace')[:40]!r} is not an ISO "
                                           "8601 time (such as 2026-05-04T10:00:00.25Z)", where=f"line {lineno}")
                if origin is not None:
                    raise InputError(name, "a second time_origin comment (give the instant t counts from once)",
                                     where=f"line {lineno}")
                origin = got
            continue
        header = line
        break
    if header is None:
        after = " after the comment lines" if comments else ""
        raise InputError(name, f"file is empty{after} (a header row with t,x,y,yaw_deg is needed)")
    where = f"line {lineno}"
    if b"\x00" in header:
        raise InputError(name, "not a text file", where=where)
    try:
        text = header.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(name, NOT_UTF8, where=where) from None
    text = text.rstrip("\r\n")
    if "\r" in text:
        raise InputError(name, "lines end in a lone carriage return (classic Mac OS line breaks): convert the "
                               "file to LF or CRLF line breaks", where=where)
    sep = _separator(text, name, where)
    cells = [h.strip().strip('"').strip() for h in text.split(sep)]
    folded = [h.lower() for h in cells]
    mixed = [s for s in SEPARATORS if s in text and s != sep]
    lay = _layout(name, sep, cells, folded, lineno, offset, comments, where, mixed)
    lay.origin = origin
    if lay.epoch and origin is not None:
        lay.base = epoch_seconds(*origin)
    return lay


def _fits(folded: list) -> bool:
    xy = "x" in folded and "y" in folded
    pos = xy or ("lon" in folded and "lat" in folded)
    return ("t" in folded or EPOCH_COLUMN in folded) and pos and (
        "yaw_deg" in folded or "heading_deg" in folded or not xy)


def _separator(text: str, name: str, where: str) -> str:
    present = [s for s in SEPARATORS if s in text]
    if not present:
        raise InputError(name, f"cannot tell the separator: the header line ({text.strip()[:80]!r}) holds no comma, "
                               "semicolon or tab; separate the columns with commas", where=where)
    if len(present) == 1:
        return present[0]
    fits = [s for s in present if _fits([h.strip().strip('"').strip().lower() for h in text.split(s)])]
    if len(fits) == 1:
        return fits[0]
    if not fits:
        return present[0]  # the missing columns are named as this separator reads them
    raise InputError(name, "cannot tell the separator: the header line splits into the required columns by "
                           f"{' and by '.join(SEP_NAMES[s] for s in fits)}; separate the columns with commas only",
                     where=where)


def _layout(name, sep, cells, folded, lineno, offset, comments, where, mixed=()) -> Layout:
    def has(c):
        return c in folded

    geographic = not (has("x") and has("y")) and has("lon") and has("lat")
    pair = ("lon", "lat") if geographic else ("x", "y")
    epoch = has(EPOCH_COLUMN) and not has("t")
    missing = [c for c in ("t",) + pair if not has(c) and not (c == "t" and epoch)]
    if has(EPOCH_COLUMN) and has("t"):
        raise InputError(name, f"the header has both t and {EPOCH_COLUMN} (seconds since 1970): keep one",
                         where=where)
    if geographic:
        if has("yaw_deg") and has("heading_deg"):
            raise InputError(name, "the header has both heading_deg (a compass bearing) and yaw_deg (counter-"
                                   "clockwise from east): keep one", where=where)
        heading = "heading_deg" if has("heading_deg") else ("yaw_deg" if has("yaw_deg") else None)
    else:
        heading = "yaw_deg"
        if not has("yaw_deg"):
            missing.append("yaw_deg")
    if missing:
        hint = ""
        if not geographic and "y" not in missing and "x" not in missing and has("heading_deg"):
            hint = ("; heading_deg (a compass bearing from true north) goes with lon, lat: with x, y give "
                    "yaw_deg, counter-clockwise from grid east")
        elif (has("lon") or has("lat")) and not geographic and ("x" in missing or "y" in missing):
            hint = "; geographic positions need both lon and lat"
        if mixed:
            hint += (f"; cannot tell the separator: the header holds {SEP_NAMES[sep]} and "
                     f"{' and '.join(SEP_NAMES[m] for m in mixed)}: separate the columns with one of them")
        found = ", ".join(cells)[:200]
        raise InputError(name, f"header lacks the required column{'s' if len(missing) > 1 else ''} "
                               f"{', '.join(missing)} (found: {found}){hint}", where=where)
    for c in KNOWN:
        if folded.count(c) > 1:
            raise InputError(name, f"column {c} appears twice in the header", where=where)
    columns = [EPOCH_COLUMN if epoch else "t", pair[0], pair[1], heading or "heading_deg"] + [
        c for c in OPTIONAL if has(c)]
    colmap = np.full(len(folded), -1, np.int32)
    for j, c in enumerate(columns):
        if j == 3 and heading is None:
            continue  # no heading column: the values stay empty (the reader takes them from the track)
        colmap[folded.index(c)] = j
    entity = has("entity")
    if entity:
        colmap[folded.index("entity")] = len(columns)
    return Layout(name=name, sep=sep, header=cells, header_line=lineno, body_start=offset, width=len(folded),
                  columns=columns, colmap=colmap, geographic=geographic, heading=heading, entity=entity,
                  has_turret=any(has(c) for c in OPTIONAL), comment_lines=comments, epoch=epoch)


class ByteSource:
    """Bytes of a stream in a growing window: ``arr[pos:end]`` unread; at most ``limit`` bytes in all."""

    def __init__(self, fh, limit: int | None = None, block: int | None = None):
        self.fh = fh
        self.left = limit
        self.block = BLOCK if block is None else block
        self.arr = np.empty(self.block, np.uint8)
        self.pos = self.end = 0
        self.eof = False

    def fill(self) -> None:
        """Drop what was read, then read more: what one read of the stream gives, up to a block (a pipe gives
        what has arrived, so rows stream as they come), or the end."""
        keep = self.end - self.pos
        if keep + self.block > len(self.arr):
            grown = np.empty(max(keep + self.block, 2 * len(self.arr)), np.uint8)
            grown[:keep] = self.arr[self.pos:self.end]
            self.arr = grown
        elif self.pos:
            self.arr[:keep] = self.arr[self.pos:self.end]
        self.pos, self.end = 0, keep
        want = self.block if self.left is None else min(self.block, self.left)
        read = getattr(self.fh, "readinto1", None) or self.fh.readinto
        got = read(memoryview(self.arr)[self.end:self.end + want]) if want > 0 else 0
        got = got or 0
        self.end += got
        if self.left is not None:
            self.left -= got
        if got == 0 or self.left == 0:
            self.eof = True


@dataclass
class RawRows:
    """One chunk's rows as read, before the checks across rows: the output columns (columns, max rows)
    (``values[j, :n]``), their lines, the entity codes (None without an entity column), and the error
    that stopped the chunk (after its rows) or None."""

    n: int
    values: np.ndarray
    line: np.ndarray
    codes: np.ndarray | None
    error: InputError | None
    done: bool


class CsvRows:
    """The rows of a trajectory CSV's body (after ``read_layout``) in chunks of ``RawRows``.

    ``names``: the entity names in code order (a list, grown as new ids appear; codes from 0)."""

    def __init__(self, layout: Layout, src: ByteSource, chunk_rows: int, line0: int):
        self.lay = layout
        self.src = src
        self.chunk_rows = max(1, int(chunk_rows))
        self.line = line0
        self.names: list = []
        self.interner = Interner() if layout.entity else None
        self.ncols = len(layout.columns) + (1 if layout.entity else 0)
        self.done = False
        self.first = True

    def next_rows(self) -> RawRows | None:
        if self.done:
            return None
        lay, src, m = self.lay, self.src, self.chunk_rows
        values = np.empty((self.ncols, m))
        line_of = np.empty(m, np.int64)
        span = np.empty((m, 2), np.int64)
        isosec = np.empty(m, np.int64)
        isons = np.empty(m, np.int64)
        codes = np.empty(m, np.int64) if lay.entity else None
        sep = ord(lay.sep)
        r = 0
        error = None
        while r < m:
            iso_col = 0 if lay.iso else -1
            r2, pos2, line2, status = parse_rows(src.arr, src.pos, src.end, src.eof, m, lay.width, sep, lay.colmap,
                                                 lay.text_col, iso_col, POW10, values, line_of, span, isosec, isons,
                                                 r, self.line)
            if status & 2:
                bad_line = self._utf8_line(src.pos, pos2)
                if bad_line is not None:
                    r2 = r + int(np.count_nonzero(line_of[r:r2] < bad_line))
                    error = InputError(lay.name, NOT_UTF8, where=f"line {bad_line}")
            if lay.entity and r2 > r:
                kept, bad = self._intern(codes, span, r, r2, line_of)
                if bad is not None:
                    r2, error = kept, bad
            if error is not None:
                r = r2
                break
            if r2 > r and lay.iso is None:
                lay.iso = False  # the first row's t is a number
            lay.blank_lines += (line2 - self.line) - (r2 - r)
            src.pos, self.line, r = pos2, line2, r2
            if status & 1:  # one line for the careful reader
                nl = _line_end(src.arr, src.pos, src.end)
                raw = bytes(src.arr[src.pos:nl])
                lineno = self.line + 1
                try:
                    row = _careful(raw, lineno, lay)
                except InputError as exc:
                    error = exc
                    break
                if row is not None:
                    vals, cell, iso = row
                    values[:len(vals), r] = vals
                    if iso is not None:
                        isosec[r], isons[r] = iso
                    line_of[r] = lineno
                    if lay.entity:
                        span[r] = (src.pos + cell[0], src.pos + cell[1])
                        kept, bad = self._intern(codes, span, r, r + 1, line_of)
                        if bad is not None:
                            error = bad
                            break
                    r += 1
                else:
                    lay.blank_lines += 1
                self.line = lineno
                src.pos = min(nl + 1, src.end)
                continue
            if r == m:
                break
            if src.eof and src.pos >= src.end:
                self.done = True
                break
            src.fill()
        if error is not None:
            self.done = True
        if lay.iso and r:
            s0, n0 = lay.t0
            values[0, :r] = ((isosec[:r] - s0) * 1_000_000_000 + (isons[:r] - n0)) / 1e9
        elif lay.epoch and r:
            if lay.base is None:
                lay.base = float(values[0, 0])
            values[0, :r] -= lay.base
        if lay.heading is None and r:
            values[3, :r] = np.nan  # no heading column: taken from the track by the reader
        if src.eof and src.pos >= src.end:
            self.done = True
        if r == 0 and error is None:
            self.done = True
            return None
        return RawRows(r, values, line_of, codes, error, self.done)

    def _utf8_line(self, a: int, b: int):
        """The line of the first byte in [a, b) that is not UTF-8, or None."""
        data = bytes(self.src.arr[a:b])
        try:
            data.decode("utf-8")
        except UnicodeDecodeError as exc:
            return self.line + data[:exc.start].count(b"\n") + 1
        return None

    def _intern(self, codes, span, a: int, b: int, line_of):
        """Codes of rows [a, b) into ``codes``; new names decoded. Returns (rows kept, None) or, where a new
        name is not UTF-8, (the rows before it, the error)."""
        got, first, first_rows = self.interner.codes(self.src.arr, span[a:b], b - a)
        codes[a:b] = got
        for k in range(first, len(self.interner)):
            try:
                self.names.append(self.interner.name(k).decode("utf-8"))
            except UnicodeDecodeError:
                row = a + int(first_rows[k - first])
                return row, InputError(self.lay.name, NOT_UTF8, where=f"line {line_of[row]}")
        return b, None


def _line_end(arr: np.ndarray, pos: int, end: int) -> int:
    """The position of the line break ending the line at ``pos`` (``end`` if none), looking a little at a time."""
    step = 4096
    at = pos
    while at < end:
        hits = np.flatnonzero(arr[at:min(at + step, end)] == 10)
        if len(hits):
            return at + int(hits[0])
        at += step
        step *= 2
    return end


def _careful(raw: bytes, lineno: int, lay: Layout):
    """One line the compiled pass left: (values, entity span in ``raw``, (s, ns) or None), None for a line
    without content, or InputError naming the line (and the column)."""
    name, where = lay.name, f"line {lineno}"
    try:
        raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(name, NOT_UTF8, where=where) from None
    body = raw[:-1] if raw.endswith(b"\r") else raw
    if b"\x00" in body:
        raise InputError(name, "not a text file (a NUL byte)", where=where)
    if not body.strip():
        return None
    if body.lstrip().startswith(b"#"):
        raise InputError(name, "a comment line after the header (comment lines go before it)", where=where)
    sep = lay.sep.encode()
    cells = body.split(sep)
    if len(cells) != lay.width:
        hint = ""
        others = [s for s in SEPARATORS if s != lay.sep and body.count(s.encode()) == lay.width - 1]
        if others:
            hint = f" (the header is split by {SEP_NAMES[lay.sep]}, this line by {SEP_NAMES[others[0]]})"
        elif lay.entity and lay.sep == "," and len(cells) > lay.width:
            hint = " (an entity id may not hold a comma)"
        raise InputError(name, f"expected {lay.width} columns as in the header, found {len(cells)}{hint}", where=where)
    values = [0.0] * len(lay.columns)
    cell_span = None
    iso = None
    starts = np.cumsum([0] + [len(c) + 1 for c in cells[:-1]])
    for ci, j in enumerate(lay.colmap.tolist()):
        if j < 0:
            continue
        cell = cells[ci]
        if j == lay.text_col:
            cell_span = _entity_cell(cell, int(starts[ci]), name, where)
            continue
        col = lay.columns[j]
        at = f"{where} column {col}"
        if j == 0:
            got = iso_seconds(cell.strip(b" \t"))
            if lay.iso is None:
                lay.iso = got is not None or bool(_ISO_START.match(cell))
                if got is not None:
                    lay.t0 = lay.origin or got
            if lay.iso:
                if got is None:
                    text = cell.decode().strip()
                    if _number(cell) is not None:
                        raise InputError(name, f"a number ({text[:40]!r}) among ISO 8601 times: the file's first row "
                                               "gives t as a date and time, every row must", where=at)
                    raise InputError(name, f"not an ISO 8601 time: {text[:40]!r} (such as 2026-05-04T10:00:00.25Z "
                                           "or 2026-05-04 12:00:00.25+02:00)", where=at)
                iso = got
                continue
            if got is not None or _ISO_START.match(cell):
                raise InputError(name, f"a date and time ({cell.decode().strip()[:40]!r}) among numbers: the file's "
                                       "first row gives t in seconds, every row must", where=at)
        values[j] = _numeric(cell, lay, name, at)
    return values, cell_span, iso


def _number(cell: bytes):
    try:
        return float(cell)
    except ValueError:
        return None


def _numeric(cell: bytes, lay: Layout, name: str, at: str) -> float:
    text = cell.decode().strip()
    value = _number(cell)
    if value is None:
        if lay.sep != "," and "," in text and _number(cell.replace(b",", b".")) is not None:
            raise InputError(name, f"a decimal comma ({text[:40]!r}) in a file separated by {SEP_NAMES[lay.sep]}: "
                                   "write the number with a point (1.5, not 1,5)", where=at)
        raise InputError(name, f"not a number: {text[:40]!r}", where=at)
    if not np.isfinite(value):
        raise InputError(name, f"non-finite value {text!r}", where=at)
    return value


def _entity_cell(cell: bytes, start: int, name: str, where: str):
    lead = len(cell) - len(cell.lstrip(b" \t"))
    value = cell.strip(b" \t")
    at = f"{where} column entity"
    text = value.decode()
    fault = entity_id_fault(text)
    if fault == "empty":
        raise InputError(name, "empty entity id (every row of a file with an entity column names its entity)",
                         where=at)
    if fault == "quote":
        raise InputError(name, f"entity id {text[:40]!r} holds a quote (an id is text without quotes or commas)",
                         where=at)
    if fault == "comma":
        raise InputError(name, f"entity id {text[:40]!r} holds a comma (an id is text without quotes or commas)",
                         where=at)
    if fault == "control":
        raise InputError(name, f"entity id {text[:40]!r} holds a control character", where=at)
    return start + lead, start + lead + len(value)


def first_row_time(fh, lay: Layout) -> None:
    """Decide ``lay.iso`` and ``lay.t0`` from the first data row after the header (``fh`` positioned there),
    for a part of a file read on its own (its times count from the file's first row)."""
    lineno = lay.header_line
    while True:
        raw = fh.readline()
        if not raw:
            return
        lineno += 1
        body = raw.rstrip(b"\r\n")
        if max(body, default=0) <= 32:
            continue
        cells = body.split(lay.sep.encode())
        cell = cells[int(np.flatnonzero(lay.colmap == 0)[0])] if len(cells) == lay.width else b""
        got = iso_seconds(cell.strip(b" \t"))
        lay.iso = got is not None or bool(_ISO_START.match(cell))
        if got is not None:
            lay.t0 = lay.origin or got
        elif lay.epoch and lay.base is None:
            lay.base = _number(cell)
        return
