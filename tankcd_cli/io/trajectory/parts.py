"""A trajectory CSV in parts, for replays that share one file among workers (``replay.windows``,
``replay.fleet``): the file cut into parts of lines (``split_trajectory``), the rows just before a
part where its first motion starts (``lead_row``), and whether the file names its entities.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.input_bytes import open_trajectory_input
from tankcd_cli.io.trajectory.chunk import TrajectoryChunk, TrajectoryPart
from tankcd_cli.io.trajectory.csv_rows import Layout, read_layout
from tankcd_cli.io.trajectory.formats import input_format, trajectory_format
from tankcd_cli.io.trajectory.reader import TrajectoryReader


def csv_layout(path: str) -> Layout:
    """A trajectory CSV's header read (InputError as the reader's)."""
    name, fh = open_trajectory_input(path)
    with fh:
        return read_layout(fh, name)


def has_entity_column(path: str) -> bool:
    """Whether a trajectory CSV's header has an ``entity`` column (False for other formats, and for a
    CSV whose header cannot be read: its replay will say what is wrong)."""
    if trajectory_format(path) != "csv":
        return False
    try:
        return bool(csv_layout(path).entity)
    except (InputError, OSError):
        return False


def lead_row(path: str, part: TrajectoryPart, crs: str | None = None) -> TrajectoryChunk | None:
    """The rows just before ``part``, where its first intervals of motion start, or None for a part that
    starts the file.

    Without an entity column: the data row just before the part (one row, with its step and line).
    With one: each entity's last row before the part (one row each, in file order; its entity
    code is this chunk's own: match entities by ``entity_names``), found by reading the file from
    its start to the part (the cost grows with what lies before the part)."""
    if part.step_offset == 0:
        return None
    lay = csv_layout(path)
    if lay.entity:
        return _lead_rows_by_entity(path, part, lay, crs)
    name, fh = open_trajectory_input(path)
    try:
        body_start = lay.body_start
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
        at = data.rindex(last)
        # the lines after it before the part (its own line break ends it: that is not one)
        gap = data[at + len(last):].count(b"\n") - 1
    finally:
        fh.close()
    line_before = part.line_offset - gap  # the lead row's own line in the whole file
    start = lo + at
    end = start + len(last) + (1 if start + len(last) < part.start else 0)
    lead = TrajectoryPart(start, end, line_before - 1, part.step_offset - 1, 1)
    chunks = list(TrajectoryReader(path, 1, lead, crs))
    return chunks[0] if chunks else None


def _lead_rows_by_entity(path: str, part: TrajectoryPart, lay: Layout, crs: str | None) -> TrajectoryChunk | None:
    before = TrajectoryPart(lay.body_start, part.start, lay.header_line, 0, part.step_offset)
    last: dict = {}
    chunks = []
    for k, chunk in enumerate(TrajectoryReader(path, 65536, before, crs)):
        rev = chunk.entity[::-1]
        codes, at = np.unique(rev, return_index=True)
        for code, j in zip(codes.tolist(), (len(rev) - 1 - at).tolist()):
            last[code] = (k, j)
        chunks.append(chunk)
        names = chunk.entity_names
        keep = {kk for kk, _ in last.values()}
        chunks = [c if i in keep else None for i, c in enumerate(chunks)]
    if not last:
        return None
    picks = sorted(last.items(), key=lambda kv: (kv[1][0], kv[1][1]))
    rows = [(chunks[k], j) for _, (k, j) in picks]

    def col(field_name):
        return np.array([getattr(c, field_name)[j] for c, j in rows])

    return TrajectoryChunk(col("step"), int(rows[0][0].line[rows[0][1]]), col("t"), col("x"), col("y"),
                           col("yaw_deg"), col("turret_deg"), col("gun_deg"), rows[0][0].has_turret, col("line"),
                           col("entity").astype(np.int64), names, np.zeros(len(rows), bool), True, "line")


def split_trajectory(path: str, lines_per_part: int, block: int = 1 << 22) -> list[TrajectoryPart]:
    """Cut a trajectory CSV into parts of ``lines_per_part`` lines after its header, counting each
    part's data rows (lines with content) so that every part knows its first step. One pass over
    the file in blocks: memory does not grow with it. Only a CSV is cut (InputError otherwise).

    With an entity column the parts cut across the entities' rows: a part's first row of an
    entity is marked ``piece_start`` in the part's chunks whether or not the entity had rows
    before it; ``lead_row`` says which had."""
    if not input_format(trajectory_format(path)).parts:
        raise InputError(path, "only a trajectory CSV is cut into parts")
    parts: list[TrajectoryPart] = []
    try:
        lay = csv_layout(path)
    except InputError:
        return []
    name, fh = open_trajectory_input(path)
    with fh:
        fh.seek(lay.body_start)
        offset, lines = lay.body_start, lay.header_line
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
