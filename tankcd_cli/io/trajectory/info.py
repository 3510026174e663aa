"""What a trajectory input holds, for ``info`` (``trajectory_info``): its format and coordinates,
rows and time span, each entity's rows, time span and pieces of motion, what was skipped.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime

import numpy as np

from tankcd_cli.io.trajectory.chunk import utc_text
from tankcd_cli.io.trajectory.reader import TrajectoryReader


@dataclass(frozen=True)
class EntitySpan:
    """One entity of a trajectory: its rows, its time span (s, as the chunks' ``t``), where its first and
    last rows are (``line``: a line or a packet) and its pieces of motion."""

    name: str
    rows: int
    t_first: float
    t_last: float
    first_line: int
    last_line: int
    pieces: int


@dataclass(frozen=True)
class TrajectoryInfo:
    """A trajectory input described (``trajectory_info``).

    format : a format name of ``formats.INPUT_FORMATS``; coordinates : ``projected`` (x, y in the terrain's CRS),
    ``geographic`` (a CSV's lon, lat; GPX), ``ecef`` (a capture); where : "line" or "packet";
    rows : all rows; t_first, t_last : over all rows (NaN without rows); start : the instant t
    counts from, where the input has one (UTC); has_entity, has_turret : as the chunks';
    entities : one :class:`EntitySpan` each, in order of first appearance; skipped : what was passed
    over, by name (a capture's packets and PDUs, a CSV's comment and blank lines); columns : the
    CSV header's names as written (empty for other formats); time_origin : the instant of t = 0 as
    ISO 8601 UTC (``...Z``, ``utc_text``), None where t is relative."""

    path: str
    format: str
    coordinates: str
    where: str
    rows: int
    t_first: float
    t_last: float
    start: datetime | None
    has_entity: bool
    has_turret: bool
    entities: tuple
    skipped: dict = field(default_factory=dict)
    columns: tuple = ()
    time_origin: str | None = None


def trajectory_info(path: str, fmt: str | None = None, chunk_rows: int = 65536) -> TrajectoryInfo:
    """Read a trajectory input once (no terrain or CRS needed: nothing is converted) and describe it.
    Raises InputError as ``read_trajectory`` does."""
    reader = TrajectoryReader(path, chunk_rows, None, None, fmt, convert=False)
    rows = np.zeros(0, np.int64)
    pieces = np.zeros(0, np.int64)
    t_first = np.zeros(0)
    t_last = np.zeros(0)
    l_first = np.zeros(0, np.int64)
    l_last = np.zeros(0, np.int64)
    has_entity = has_turret = False
    names: tuple = ()
    for chunk in reader:
        names = chunk.entity_names
        m = len(names)
        if len(rows) < m:
            grow = m - len(rows)
            rows, pieces = np.r_[rows, np.zeros(grow, np.int64)], np.r_[pieces, np.zeros(grow, np.int64)]
            t_first, t_last = np.r_[t_first, np.full(grow, np.nan)], np.r_[t_last, np.full(grow, np.nan)]
            l_first, l_last = np.r_[l_first, np.zeros(grow, np.int64)], np.r_[l_last, np.zeros(grow, np.int64)]
        codes = chunk.entity
        rows += np.bincount(codes, minlength=m)
        pieces += np.bincount(codes[chunk.piece_start], minlength=m)
        u, at = np.unique(codes, return_index=True)
        new = np.isnan(t_first[u])
        t_first[u[new]], l_first[u[new]] = chunk.t[at[new]], chunk.line[at[new]]
        rev = codes[::-1]
        u, at = np.unique(rev, return_index=True)
        j = len(codes) - 1 - at
        t_last[u], l_last[u] = chunk.t[j], chunk.line[j]
        has_entity |= chunk.has_entity
        has_turret |= chunk.has_turret
    coords = reader.coordinates
    entities = tuple(EntitySpan(names[k], int(rows[k]), float(t_first[k]), float(t_last[k]), int(l_first[k]),
                                int(l_last[k]), int(pieces[k])) for k in range(len(names)))
    columns = reader.columns
    total = int(rows.sum())
    return TrajectoryInfo(path=path, format=reader.format, coordinates=coords, where=reader.where, rows=total,
                          t_first=float(np.nanmin(t_first)) if total else float("nan"),
                          t_last=float(np.nanmax(t_last)) if total else float("nan"), start=reader.start,
                          has_entity=has_entity, has_turret=has_turret, entities=entities,
                          skipped=dict(reader.skipped), columns=columns, time_origin=utc_text(reader.time_origin))
