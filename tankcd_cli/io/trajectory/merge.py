"""Several trajectory inputs as one exercise (``merged_trajectories``, for ``replay --together``):
their rows merged in time order, aligned on their clocks.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.trajectory.chunk import TrajectoryChunk, utc_text
from tankcd_cli.io.trajectory.reader import read_trajectory


def merged_trajectories(paths: list, chunk_rows: int = 65536, crs: str | None = None) -> Iterator[TrajectoryChunk]:
    """Several trajectory inputs as one exercise (``replay --together``): their rows merged in time
    order (rows of equal time in the order of the files), chunk by chunk, in memory of a chunk per
    file. Each file is one entity named after its stem, or its own entities when it names them
    (``has_entity``); the names are the exercise's, so two files naming the same entity is an
    InputError naming both. Steps count the merged rows from 0; each row keeps its file's line
    (messages name the file of a bad row: each file is read by its own reader).

    Files with an absolute clock (``time_origin``: GPX, captures, CSVs with ISO 8601 or ``unix_time``
    times or a ``# time_origin`` comment) are aligned on it: t counts from the earliest origin of
    them all (each file's rows shifted by its origin's distance from it), and the chunks carry that
    origin. Files without one are lined up by their own t. A mix of the two is an InputError naming
    a file of each kind."""
    readers = [read_trajectory(p, chunk_rows=chunk_rows, crs=crs) for p in paths]
    kinds = {r.where for r in readers}
    where = kinds.pop() if len(kinds) == 1 else "line"  # what the rows' numbers count, where all files agree
    pending: list = [None] * len(readers)  # each reader's unread rows: a chunk and where it starts
    alive = list(range(len(readers)))
    names: list = []
    owner: dict = {}  # name -> the file that brought it
    maps: list = [np.zeros(0, dtype=np.int64) for _ in readers]  # per reader: local code -> exercise code
    step = 0
    has_turret = False
    shift = [0.0] * len(readers)  # s added to each file's t: its origin's distance from the exercise's
    origin = None

    def global_codes(k, chunk):
        local = chunk.entity_names if chunk.has_entity else (os.path.splitext(os.path.basename(paths[k]))[0],)
        m = maps[k]
        for name in local[len(m):]:
            if name in owner and owner[name] != paths[k]:
                raise InputError(paths[k], f"entity {name!r} is also in {owner[name]}: give every vehicle its own "
                                           "name")
            owner[name] = paths[k]
            names.append(name)
            m = np.append(m, len(names) - 1)
        maps[k] = m
        codes = chunk.entity if chunk.has_entity else np.zeros(len(chunk), dtype=np.int64)
        return m[codes]

    def fill(k):
        while pending[k] is None or pending[k][1] >= len(pending[k][0]):
            chunk = next(readers[k], None)
            if chunk is None:
                return False
            if len(chunk):
                if shift[k]:
                    chunk = dataclasses.replace(chunk, t=chunk.t + shift[k])
                pending[k] = (chunk, 0, global_codes(k, chunk))
        return True

    alive = [k for k in alive if fill(k)]
    origins = {k: pending[k][0].time_origin for k in alive}
    timed = [k for k in alive if origins[k] is not None]
    if timed and len(timed) < len(alive):
        a, r = timed[0], next(k for k in alive if origins[k] is None)
        raise InputError(paths[a], f"has absolute times (from {utc_text(origins[a])}) and {paths[r]} relative ones "
                                   "(seconds from its first row): they cannot be aligned; give both an absolute "
                                   "clock (ISO 8601 times, unix_time, or a '# time_origin:' comment: docs/formats.md) "
                                   "or neither")
    if timed:
        origin = min(origins[k] for k in timed)
        for k in timed:
            shift[k] = origins[k] - origin
            if shift[k]:
                chunk, at, codes = pending[k]
                pending[k] = (dataclasses.replace(chunk, t=chunk.t + shift[k]), at, codes)
    while alive:
        # every row up to the earliest last time in the files' pending chunks can go now
        limit = min(float(pending[k][0].t[-1]) for k in alive)
        taken = []
        for k in alive:
            chunk, at, codes = pending[k]
            end = at + int(np.searchsorted(chunk.t[at:], limit, side="right"))
            if end > at:
                taken.append((k, chunk, np.arange(at, end), codes[at:end]))
                pending[k] = (chunk, end, codes)
        parts = []
        for k, chunk, idx, codes in taken:
            parts.append((chunk.t[idx], k, idx, chunk, codes))
        t = np.concatenate([p[0] for p in parts])
        order = np.lexsort((np.concatenate([np.full(len(p[0]), p[1]) for p in parts]), t))
        cat = {f: np.concatenate([getattr(p[3], f)[p[2]] for p in parts])[order]
               for f in ("t", "x", "y", "yaw_deg", "turret_deg", "gun_deg", "line")}
        entity = np.concatenate([p[4] for p in parts])[order]
        piece = np.concatenate([(p[3].piece_start[p[2]] if p[3].piece_start is not None
                                 else np.zeros(len(p[2]), dtype=bool)) for p in parts])[order]
        has_turret = has_turret or any(p[3].has_turret for p in parts)
        n = len(t)
        for start in range(0, n, chunk_rows):
            sl = slice(start, min(start + chunk_rows, n))
            yield TrajectoryChunk(np.arange(step + sl.start, step + sl.stop), int(cat["line"][sl.start]), cat["t"][sl],
                                  cat["x"][sl], cat["y"][sl], cat["yaw_deg"][sl], cat["turret_deg"][sl],
                                  cat["gun_deg"][sl], has_turret, cat["line"][sl], entity[sl], tuple(names),
                                  piece[sl], True, where, origin)
        step += n
        alive = [k for k in alive if fill(k)]
