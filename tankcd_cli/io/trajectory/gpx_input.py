"""GPX tracks as chunks (docs/formats.md, "GPX tracks"): the ``gpx`` format of
``formats.INPUT_FORMATS``. ``io.gpx`` reads the track points; here each track is an entity
(named by ``track_names``), each segment a piece of motion, the points converted to the
terrain's CRS.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.geodesy import to_terrain_crs
from tankcd_cli.io.gpx import read_gpx
from tankcd_cli.io.trajectory.chunk import EntityOrder, ReadState, TrajectoryChunk
from tankcd_cli.io.trajectory.geographic_csv import check_crs
from tankcd_cli.io.trajectory.names import EntityNames, entity_id_from


def looks_like_gpx(head: bytes) -> bool:
    """Whether an input's first bytes (decompressed) are XML: ``<`` after a byte-order mark and blanks."""
    text = head[3:] if head.startswith(b"\xef\xbb\xbf") else head
    return text.lstrip().startswith(b"<")


def read_chunks(state: ReadState) -> Iterator[TrajectoryChunk]:
    """The chunks of the GPX file ``state.path`` (read whole: the file is in memory), ``state``'s clock set."""
    if state.convert:
        check_crs(state.crs, state.path)
    g = read_gpx(state.path)
    state.start = g.start
    state.time_origin = g.origin
    names = EntityNames(track_names(g.track_names))
    n = len(g)
    codes = g.track.astype(np.int64)
    piece_start = np.r_[True, g.piece[1:] != g.piece[:-1]]
    order = EntityOrder()
    _, bad = order.check(codes, g.t, g.line, len(names.list))
    heading = fill_by_entity(g.heading, codes)
    ends = n if bad < 0 else bad
    # the tracks come one after another in the file, not in time order: as one chunk (the file is
    # in memory already) the checks between vehicles see every track's motion at every time
    step = state.chunk_rows if len(names.list) <= 1 else max(ends, 1)
    for lo in range(0, ends, step):
        hi = min(lo + step, ends)
        if state.convert:
            x, y, yaw = to_terrain_crs(g.lon[lo:hi], g.lat[lo:hi], state.crs, heading=heading[lo:hi],
                                       source=state.path)
            yaw = np.degrees(yaw)
            yaw[np.isnan(heading[lo:hi])] = 0.0  # a track that never moves: no heading to give
        elif state.lonlat:  # the local ENU yaw
            x, y, yaw = g.lon[lo:hi], g.lat[lo:hi], np.nan_to_num(90.0 - np.degrees(heading[lo:hi]), nan=0.0)
        else:
            x, y, yaw = g.lon[lo:hi], g.lat[lo:hi], np.degrees(heading[lo:hi])
        top = int(codes[hi - 1]) + 1  # tracks come in file order: the names seen so far
        zeros = np.zeros(hi - lo)
        point = np.arange(lo + 1, hi + 1)  # a track point by its number from 1 (its line says little in
        # a file written on one line, as many are)
        yield TrajectoryChunk(np.arange(lo, hi), lo + 1, g.t[lo:hi], x, y, yaw, zeros, zeros, False,
                              point, codes[lo:hi], tuple(names.list[:top]), piece_start[lo:hi], True,
                              "trkpt", state.time_origin)
    if bad >= 0:
        k = bad
        prev = order.last_t[codes[k]]
        raise InputError(state.path, f"track {names.list[codes[k]]!r}: time goes back ({float(g.t[k])!r} s after "
                                     f"{float(prev)!r} s at line {int(order.last_line[codes[k]])}): a track's "
                                     "segments must follow one another in time",
                         where=f"trkpt {k + 1} (line {int(g.line[k])})")


def fill_by_entity(values: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """NaN values filled from the same entity's nearest known value before them, else after them (NaN where
    the entity has none); the entities' rows contiguous."""
    n = len(values)
    out = np.array(values, dtype=np.float64)
    known = ~np.isnan(out)
    if known.all() or not n:
        return out
    idx = np.arange(n)
    start = np.r_[True, codes[1:] != codes[:-1]]
    first = np.maximum.accumulate(np.where(start, idx, 0))
    last = np.minimum.accumulate(np.where(np.r_[start[1:], True], idx, n)[::-1])[::-1]
    before = np.maximum.accumulate(np.where(known, idx, -1))
    after = np.minimum.accumulate(np.where(known, idx, n)[::-1])[::-1]
    use = np.where(before >= first, before, np.where(after <= last, after, -1))
    ok = use >= 0
    out[ok] = out[use[ok]]
    return out


def track_names(raw: list) -> list:
    """GPX track names as entity ids: a track's name with the characters an id may not hold replaced
    ('_' instead), ``trackK`` (K from 1) for a track without one; a name already taken gains ``_2``, ``_3``..."""
    names, taken = [], set()
    for k, name in enumerate(raw):
        base = entity_id_from(name).strip() or f"track{k + 1}"
        got, j = base, 2
        while got in taken:
            got, j = f"{base}_{j}", j + 1
        taken.add(got)
        names.append(got)
    return names
