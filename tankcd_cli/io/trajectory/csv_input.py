"""The trajectory CSV as chunks (docs/formats.md, "Trajectory CSV"): the ``csv`` format of
``formats.INPUT_FORMATS``. ``csv_rows`` reads the header and the rows (a compiled pass, no Python
work a row); here each chunk's rows are checked across rows (gun elevations, each entity's time
order) and made a :class:`TrajectoryChunk`; a CSV in lon, lat goes through ``geographic_csv``.
A part of a file (``ReadState.part``) is read on its own, its steps and lines the whole file's.
"""

from __future__ import annotations

from datetime import timedelta
from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.input_bytes import open_trajectory_input
from tankcd_cli.io.trajectory.chunk import GUN_LIMIT_DEG, EPOCH, EntityOrder, ReadState, TrajectoryChunk
from tankcd_cli.io.trajectory.csv_rows import ByteSource, CsvRows, Layout, RawRows, first_row_time, read_layout
from tankcd_cli.io.trajectory.geographic_csv import check_crs, headed_from_track, out_of_range, positions
from tankcd_cli.io.trajectory.names import EntityNames, stem_name


def read_chunks(state: ReadState) -> Iterator[TrajectoryChunk]:
    """The chunks of the CSV ``state.path`` (only ``state.part``'s rows where given), ``state`` kept up to
    date (its columns, whether geographic, its clock, the lines skipped). Every bad row is an
    InputError naming the line, after the chunk of the rows before it."""
    name, fh = open_trajectory_input(state.path)
    try:
        lay = read_layout(fh, name)
        state.geographic = lay.geographic
        state.coordinates = "geographic" if lay.geographic else "projected"
        state.columns = tuple(lay.header)
        if lay.geographic and state.convert:
            check_crs(state.crs, name)
        part = state.part
        if part is not None:
            first_row_time(fh, lay)
            fh.seek(part.start)
            src = ByteSource(fh, limit=part.end - part.start)
            rows = CsvRows(lay, src, state.chunk_rows, part.line_offset)
            step = part.step_offset
        else:
            rows = CsvRows(lay, ByteSource(fh), state.chunk_rows, lay.header_line)
            step = 0
        names = EntityNames(() if lay.entity else (stem_name(state.path),))
        order = EntityOrder()
        if not lay.entity and step > 0:
            order.check(np.zeros(1, np.int64), np.array([-np.inf]), np.zeros(1, np.int64), 1)  # a row before
        where_t = {c: j for j, c in enumerate(lay.columns)}
        # no heading column: the track's (not needed to describe the file, unconverted)
        raws = headed_from_track(rows, lay) if lay.heading is None and (state.convert or state.lonlat) else None
        while True:
            raw = rows.next_rows() if raws is None else next(raws, None)
            state.skipped = {k: v for k, v in (("comment_lines", lay.comment_lines),
                                               ("blank_lines", lay.blank_lines)) if v}
            if raw is None:
                return
            if state.time_origin is None and lay.time_origin is not None:
                state.time_origin = lay.time_origin
                state.start = EPOCH + (timedelta(seconds=lay.t0[0], microseconds=lay.t0[1] // 1000) if lay.iso
                                       else timedelta(microseconds=round(lay.time_origin * 1e6)))
            if lay.entity:
                for nm in rows.names[len(names.list):]:
                    names.add(nm)
            chunk, error = _chunk(state, raw, lay, names, order, where_t, step)
            if chunk is not None:
                step += len(chunk)
                yield chunk
            if error is not None:
                raise error
    finally:
        if state.path != "-":
            fh.close()


def _chunk(state: ReadState, raw: RawRows, lay: Layout, names: EntityNames, order: EntityOrder, col: dict,
           step: int) -> tuple[TrajectoryChunk | None, InputError | None]:
    """One chunk's raw rows checked across rows: (the chunk of the rows before the first bad one, or None
    for none; that row's InputError or the one the raw rows ended with, or None)."""
    n, v = raw.n, raw.values
    error = raw.error
    t = v[0, :n]
    a, b, h = v[1, :n], v[2, :n], v[3, :n]
    lines = raw.line[:n]
    codes = raw.codes[:n] if lay.entity else np.zeros(n, np.int64)
    k = n
    if lay.geographic:
        k, bad_place = out_of_range(a, b, lines, lay.name)
        if bad_place is not None:
            error = bad_place
    if "gun_deg" in col:
        bad = np.flatnonzero(~(np.abs(v[col["gun_deg"], :k]) <= GUN_LIMIT_DEG))
        if len(bad):
            k = int(bad[0])
            error = InputError(lay.name, f"{float(v[col['gun_deg'], k])!r} is no gun elevation (-{GUN_LIMIT_DEG:g} "
                                         f"to {GUN_LIMIT_DEG:g} degrees)", where=f"line {lines[k]} column gun_deg")
    piece, bad = order.check(codes[:k], t[:k], lines[:k], len(names.list))
    if bad >= 0:
        error = _order_error(lay.name, lay.entity, names, order, codes[bad], t[bad], lines[bad])
        k = bad
    if lay.geographic:
        x, y, yaw, k, bad_place = positions(a[:k], b[:k], h[:k], lines[:k], lay, state)
        if bad_place is not None:
            error = bad_place
    else:
        x, y, yaw = a[:k], b[:k], h[:k]
    if k == 0:
        return None, error
    zeros = None

    def optional(c):
        nonlocal zeros
        if c in col:
            return v[col[c], :k]
        if zeros is None:
            zeros = np.zeros(k)
        return zeros

    chunk = TrajectoryChunk(np.arange(step, step + k), int(lines[0]), t[:k], x, y, yaw, optional("turret_deg"),
                            optional("gun_deg"), lay.has_turret, lines[:k], codes[:k], names.tuple(), piece[:k],
                            lay.entity, "line", state.time_origin)
    return chunk, error


def _order_error(name: str, has_entity: bool, names: EntityNames, order: EntityOrder, code, t, line) -> InputError:
    prev = float(order.last_t[code])
    if not has_entity:
        return InputError(name, f"time goes back ({float(t)!r} after {prev!r}); t must be non-decreasing",
                          where=f"line {line} column t")
    return InputError(name, f"entity {names.list[code]!r}: time goes back ({float(t)!r} after {prev!r} on "
                            f"line {int(order.last_line[code])}); each entity's t must be non-decreasing",
                      where=f"line {line}")
