"""Trajectory CSV (docs/formats.md; the input of ``replay``), read in chunks and validated strictly.

Header row required, column order free, extra columns ignored. Required:
``t`` (s, non-decreasing), ``x``, ``y`` (m), ``yaw_deg``; optional
``turret_deg``, ``gun_deg`` (0 when absent). Every bad row is exit 3 naming
the line and the column.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.files import open_input

REQUIRED = ("t", "x", "y", "yaw_deg")
OPTIONAL = ("turret_deg", "gun_deg")


@dataclass(frozen=True)
class TrajectoryChunk:
    """Consecutive rows: step (row index from 0), first_line (file line of the first row), columns (N,),
    line (N,) the file line of each row."""

    step: np.ndarray
    first_line: int
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw_deg: np.ndarray
    turret_deg: np.ndarray
    gun_deg: np.ndarray
    has_turret: bool
    line: np.ndarray = None

    def __len__(self) -> int:
        return len(self.t)


@dataclass(frozen=True)
class TrajectoryPart:
    """Rows of a trajectory file read on their own: bytes [start, end) after the header,
    ``line_offset`` file lines before them, ``step_offset`` data rows before them, ``rows`` of their own."""

    start: int
    end: int
    line_offset: int
    step_offset: int
    rows: int


def lead_row(path: str, part: TrajectoryPart) -> TrajectoryChunk | None:
    """The data row just before ``part`` (one row, with its step and line), or None for a part that
    starts the file: the row a part's first interval of motion starts from."""
    import io

    if part.step_offset == 0:
        return None
    name, fh = open_input(path, text=False)
    try:
        header = b""
        while not header.strip():
            line = fh.readline()
            if not line:
                return None
            header = line
        body_start = fh.tell()
        back = 4096
        while True:  # the last line with content before the part's first byte
            lo = max(body_start, part.start - back)
            fh.seek(lo)
            data = fh.read(part.start - lo)
            lines = [ln for ln in data.split(b"\n") if ln.strip()]
            if lines and (lo == body_start or len(lines) > 1):
                break
            if lo == body_start:
                return None
            back *= 4
        last = lines[-1]
        # the lines after it before the part (its own line break ends it: that is not one)
        gap = data[data.rindex(last) + len(last):].count(b"\n") - 1
        text = header.decode("utf-8-sig") + last.decode("utf-8") + "\n"
    except UnicodeDecodeError:
        raise InputError(name, "not UTF-8 text (a trajectory is a CSV file)") from None
    finally:
        fh.close()
    line_before = part.line_offset - gap  # the lead row's own line in the whole file
    chunks = list(_chunks(io.StringIO(text, newline=""), name, 1, part.step_offset - 1, line_before - 1))
    return chunks[0] if chunks else None


def read_trajectory(path: str, chunk_rows: int = 65536, part: TrajectoryPart | None = None) -> Iterator[TrajectoryChunk]:
    """Yield validated chunks of a trajectory CSV in file order (only ``part``'s rows, if given:
    steps and line numbers stay those of the whole file)."""
    if part is not None:
        yield from _part_chunks(path, chunk_rows, part)
        return
    name, fh = open_input(path, text=True)
    try:
        yield from _chunks(fh, name, chunk_rows)
    except UnicodeDecodeError:
        raise InputError(name, "not UTF-8 text (a trajectory is a CSV file)") from None
    finally:
        if path != "-":
            fh.close()


def _part_chunks(path: str, chunk_rows: int, part: TrajectoryPart) -> Iterator[TrajectoryChunk]:
    import io

    name, fh = open_input(path, text=False)
    try:
        header = b""
        while not header.strip():
            line = fh.readline()
            if not line:
                break
            header = line
        fh.seek(part.start)
        body = fh.read(part.end - part.start)
        try:
            text = header.decode("utf-8-sig") + body.decode("utf-8")
        except UnicodeDecodeError:
            raise InputError(name, "not UTF-8 text (a trajectory is a CSV file)") from None
    finally:
        fh.close()
    yield from _chunks(io.StringIO(text, newline=""), name, chunk_rows, part.step_offset, part.line_offset)


def split_trajectory(path: str, lines_per_part: int, block: int = 1 << 22) -> list[TrajectoryPart]:
    """Cut a trajectory file into parts of ``lines_per_part`` lines after its header, counting each
    part's data rows (lines with content) so that every part knows its first step. One pass over
    the file in blocks: memory does not grow with it."""
    parts: list[TrajectoryPart] = []
    name, fh = open_input(path, text=False)
    with fh:
        offset = lines = 0
        while True:  # the header: the first line with content
            line = fh.readline()
            if not line:
                return []
            offset += len(line)
            lines += 1
            if line.strip():
                break
        start, start_line, step = offset, lines, 0
        rows = count = 0
        has = False  # the line in progress has content
        pos = offset
        while True:
            data = fh.read(block)
            if not data:
                break
            b = np.frombuffer(data, np.uint8)
            nl = np.flatnonzero(b == 10)
            content = np.cumsum(b > 32)
            if len(nl):
                begins = np.concatenate([[0], content[nl[:-1]]])
                line_has = (content[nl] - begins) > 0
                line_has[0] |= has
                i = 0
                while i < len(nl):
                    take = min(lines_per_part - count, len(nl) - i)
                    rows += int(line_has[i:i + take].sum())
                    count += take
                    i += take
                    if count == lines_per_part:
                        end = pos + int(nl[i - 1]) + 1
                        parts.append(TrajectoryPart(start, end, start_line, step, rows))
                        step += rows
                        start_line += count
                        start, rows, count = end, 0, 0
                has = bool(content[-1] - content[nl[-1]] > 0)
            else:
                has = has or bool(content[-1] > 0)
            pos += len(data)
        if pos > start:
            parts.append(TrajectoryPart(start, pos, start_line, step, rows + (1 if has else 0)))
    return parts


def _chunks(fh, name: str, chunk_rows: int, first_step: int = 0,
            line_offset: int | None = None) -> Iterator[TrajectoryChunk]:
    from tankcd_cli.io.csv_columns import numeric_chunks

    step = first_step
    last_t = -np.inf
    for rows, wanted, values in numeric_chunks(fh, name, REQUIRED, OPTIONAL, chunk_rows, line_offset=line_offset):
        t = values[:, 0]
        order_bad = np.flatnonzero(np.diff(np.concatenate([[last_t], t])) < 0)
        error = None
        if len(order_bad):
            k = int(order_bad[0])
            prev = last_t if k == 0 else t[k - 1]
            error = InputError(name, f"time goes back ({float(t[k])!r} after {float(prev)!r}); "
                                     "t must be non-decreasing",
                               where=f"line {rows[k]} column t")
            values, rows, t = values[:k], rows[:k], t[:k]
            if k == 0:
                raise error
        last_t = t[-1]
        n = len(t)
        turret = values[:, wanted.index("turret_deg")] if "turret_deg" in wanted else np.zeros(n)
        gun = values[:, wanted.index("gun_deg")] if "gun_deg" in wanted else np.zeros(n)
        yield TrajectoryChunk(np.arange(step, step + n), rows[0], t, values[:, 1], values[:, 2], values[:, 3],
                              turret, gun, any(c in wanted for c in OPTIONAL), np.asarray(rows[:n]))
        step += n
        if error is not None:
            raise error
