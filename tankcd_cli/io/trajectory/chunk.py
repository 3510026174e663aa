"""The chunk model every trajectory reader yields (docs/formats.md, "Trajectory CSV" and "Times and
clocks"): :class:`TrajectoryChunk` (rows in the input's order), :class:`TrajectoryPart` (a CSV's
rows read on their own), :class:`ReadState` (what a reader is asked and learns as it reads), each
entity's time order across chunks (:class:`EntityOrder`) and the text of a clock's origin
(``utc_text``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from decimal import ROUND_FLOOR, Decimal

import numpy as np

from tankcd_cli.io.csv_kernels import entity_order
from tankcd_cli.io.dis import CaptureCounts

REQUIRED = ("t", "x", "y", "yaw_deg")
OPTIONAL = ("turret_deg", "gun_deg")
GUN_LIMIT_DEG = 180.0  # a gun elevation beyond a half turn means nothing (and would spin the gun's path without end)
EPOCH = datetime(1970, 1, 1, tzinfo=timezone.utc)


@dataclass(frozen=True)
class TrajectoryChunk:
    """Consecutive rows of a trajectory, N of them, in the input's order.

    step : (N,) int64 the row's index in the input (from 0; a part keeps the whole file's numbers)
    first_line : the first row's ``line``
    t : (N,) float64 s; x, y : (N,) float64 m in the terrain's CRS; yaw_deg : (N,) float64 from grid
        east, counter-clockwise; turret_deg, gun_deg : (N,) float64 (0 where the input has none)
    has_turret : the input gives turret or gun angles (a CSV's columns; a capture's articulated
        parts, in any PDU up to this chunk's end)
    line : (N,) int64 where each row is, for messages: what ``where`` says (a CSV's file line, a GPX
        track point's ``<trkpt`` line, a capture's packet number from 1)
    entity : (N,) int64 each row's entity, a code into ``entity_names``; 0 throughout (named after
        the file's stem) for an input without entities
    entity_names : every entity name seen up to this chunk's end; codes never change as it grows
        (``entity_names[entity[i]]`` is row i's name)
    piece_start : (N,) bool the row starts a piece of motion of its entity: no motion from that
        entity's previous row to it (the entity's first row, a GPX segment's first point)
    has_entity : the input names its entities (an entity column, GPX tracks, DIS entity ids)
    where : "line", "trkpt" (a GPX track point's number from 1) or "packet"
    time_origin : the UTC instant of t = 0 as seconds since 1970 (float64: about 0.2 us at today's
        dates), where the input carries an absolute clock (GPX times, a capture's packet times, a
        CSV's ISO 8601 or ``unix_time`` times or ``# time_origin`` comment); None: t is relative
    """

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
    entity: np.ndarray = None
    entity_names: tuple = ()
    piece_start: np.ndarray = None
    has_entity: bool = False
    where: str = "line"
    time_origin: float | None = None

    def __len__(self) -> int:
        return len(self.t)

    def names(self) -> np.ndarray:
        """(N,) str: each row's entity name."""
        return np.asarray(self.entity_names, dtype=str)[self.entity] if len(self) else np.zeros(0, str)


@dataclass(frozen=True)
class TrajectoryPart:
    """Rows of a trajectory file read on their own: bytes [start, end) after the header,
    ``line_offset`` file lines before them, ``step_offset`` data rows before them, ``rows`` of their own."""

    start: int
    end: int
    line_offset: int
    step_offset: int
    rows: int


@dataclass(eq=False)
class ReadState:
    """What a trajectory reader is asked (the first six) and what it learns as it reads (the rest); each
    format's ``read_chunks(state)`` reads the first and keeps the rest up to date.

    path : the input ('-' standard input); chunk_rows : rows a chunk at most; part : a CSV's part or None
    crs : the terrain's CRS (None or empty: none); convert : geographic inputs converted to ``crs``
    lonlat : the chunks give x = lon, y = lat (deg, WGS 84) and yaw_deg counter-clockwise from true
        east (the local ENU yaw) instead of the terrain's CRS (``export`` to EPSG:4326)
    format : the input's format name (``formats.INPUT_FORMATS``); where : what a chunk's ``line`` counts
    coordinates : ``projected``, ``geographic`` or ``ecef`` (a CSV's: from its header)
    geographic : positions in lon, lat or ECEF (None before a CSV's header is read)
    entity_names : the names seen so far (as the last chunk's)
    start : the instant ``t`` counts from where the input has one, UTC
    time_origin : the same as seconds since 1970 (the chunks'), None where t is relative
    skipped : what was passed over, by name; complete once the chunks are exhausted
    counts : a capture's :class:`~tankcd_cli.io.dis.CaptureCounts` (None for other inputs)
    columns : a CSV header's names as written (empty for other formats)
    """

    path: str
    chunk_rows: int
    part: TrajectoryPart | None
    crs: str | None
    convert: bool
    lonlat: bool
    format: str = "csv"
    where: str = "line"
    coordinates: str = "projected"
    geographic: bool | None = None
    entity_names: tuple = ()
    start: datetime | None = None
    time_origin: float | None = None
    skipped: dict = field(default_factory=dict)
    counts: CaptureCounts | None = None
    columns: tuple = ()


class EntityOrder:
    """Each entity's time never going back, across chunks (the compiled check's state by code)."""

    def __init__(self):
        self.last_t = np.full(16, np.nan)
        self.last_line = np.zeros(16, np.int64)
        self.seen = np.zeros(16, np.uint8)

    def check(self, codes, t, lines, ncodes: int):
        """(piece_start (n,) bool, first row whose time goes back or -1)."""
        if ncodes > len(self.seen):
            grow = max(ncodes, 2 * len(self.seen)) - len(self.seen)
            self.last_t = np.r_[self.last_t, np.full(grow, np.nan)]
            self.last_line = np.r_[self.last_line, np.zeros(grow, np.int64)]
            self.seen = np.r_[self.seen, np.zeros(grow, np.uint8)]
        piece = np.empty(len(codes), np.uint8)
        bad = entity_order(np.ascontiguousarray(codes, dtype=np.int64), np.ascontiguousarray(t, dtype=np.float64),
                           np.ascontiguousarray(lines, dtype=np.int64), self.last_t, self.last_line, self.seen, piece)
        return piece.view(bool), bad


def utc_text(origin: float | None) -> str | None:
    """Seconds since 1970 -> ISO 8601 UTC (``2026-05-04T10:00:00.05Z``), None for None. The fraction is
    the float's shortest decimal (``repr``'s: 7 digits at most at today's dates), so that
    ``csv_rows.iso_seconds`` and ``epoch_seconds`` read it back into the same float64."""
    if origin is None:
        return None
    exact = Decimal(repr(float(origin)))
    if exact.as_tuple().exponent < -9:  # before 1973 a float holds more than nanoseconds: to 1 ns
        exact = exact.quantize(Decimal(1).scaleb(-9))
    whole = int(exact.to_integral_value(rounding=ROUND_FLOOR))
    frac = format(exact - whole, "f")  # "0.05", "0"
    text = (EPOCH + timedelta(seconds=whole)).strftime("%Y-%m-%dT%H:%M:%S")
    digits = frac.partition(".")[2].rstrip("0")
    return text + (f".{digits}" if digits else "") + "Z"
