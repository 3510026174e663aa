"""Trajectories in (docs/formats.md, "Trajectory CSV" and "Recorded and geographic trajectories"): one
reader for every input a user holds, as chunks a replay streams.

``read_trajectory(path, chunk_rows, part, crs, fmt)`` reads, chosen by suffix or ``fmt``:

- ``csv``: the trajectory CSV (``t``, ``x``, ``y``, ``yaw_deg``; optional ``turret_deg``, ``gun_deg``,
  ``entity``), also as logs are kept (comment lines before the header, header names in any case,
  ``;`` or tab as separator, ISO 8601 times, ``unix_time``), and in geographic coordinates (``lon``,
  ``lat``, ``heading_deg`` or ``yaw_deg`` or none: converted to the terrain's CRS); see ``trajectory_csv``;
- ``gpx``: GPX tracks (each track an entity, each segment a piece of motion);
- ``pcap``, ``pcapng``: DIS captures (each ``site:application:entity`` an entity).

Every chunk is a :class:`TrajectoryChunk`: rows in the input's order, positions and headings in
the terrain's CRS, each row's entity as a code into the names seen so far, and where each
entity's pieces of motion start, and where the input has an absolute clock the UTC instant of
its t = 0 (``time_origin``, docs/formats.md "Times and clocks"). Every bad row or record is an
:class:`InputError` naming the file and the line (or point, or packet); the rows before it have
been yielded.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.input_formats import FORMAT_NAMES, open_trajectory_input, trajectory_input

REQUIRED = ("t", "x", "y", "yaw_deg")
OPTIONAL = ("turret_deg", "gun_deg")
FORMATS = FORMAT_NAMES
EXPORT_COLUMNS = ("t", "entity", "x", "y", "yaw_deg", "turret_deg", "gun_deg")  # turret, gun: where the input has them
GUN_LIMIT_DEG = 180.0  # a gun elevation beyond a half turn means nothing (and would spin the gun's path without end)
REORDER_WINDOW = 1.0  # s: a capture's packets this much out of time order are put back in order
_EPOCH = datetime(1970, 1, 1, tzinfo=timezone.utc)


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


class _Names:
    """Entity names in code order, each code fixed once given."""

    def __init__(self, names=()):
        self.list: list = []
        self.index: dict = {}
        self._tuple: tuple = ()
        for name in names:
            self.add(name)

    def add(self, name: str) -> int:
        code = self.index.get(name)
        if code is None:
            code = self.index[name] = len(self.list)
            self.list.append(name)
        return code

    def tuple(self) -> tuple:
        if len(self._tuple) != len(self.list):
            self._tuple = tuple(self.list)
        return self._tuple


class _Order:
    """Each entity's time never going back, across chunks (the compiled check's state by code)."""

    def __init__(self):
        self.last_t = np.full(16, np.nan)
        self.last_line = np.zeros(16, np.int64)
        self.seen = np.zeros(16, np.uint8)

    def check(self, codes, t, lines, ncodes: int):
        """(piece_start (n,) bool, first row whose time goes back or -1)."""
        from tankcd_cli.io.csv_kernels import entity_order

        if ncodes > len(self.seen):
            grow = max(ncodes, 2 * len(self.seen)) - len(self.seen)
            self.last_t = np.r_[self.last_t, np.full(grow, np.nan)]
            self.last_line = np.r_[self.last_line, np.zeros(grow, np.int64)]
            self.seen = np.r_[self.seen, np.zeros(grow, np.uint8)]
        piece = np.empty(len(codes), np.uint8)
        bad = entity_order(np.ascontiguousarray(codes, dtype=np.int64), np.ascontiguousarray(t, dtype=np.float64),
                           np.ascontiguousarray(lines, dtype=np.int64), self.last_t, self.last_line, self.seen, piece)
        return piece.view(bool), bad


def trajectory_format(path: str, fmt: str | None = None) -> str:
    """``csv``, ``gpx``, ``pcap`` or ``pcapng``: ``fmt`` if given, else by the suffix (``.gz`` passed
    over), else by the first bytes (``io.input_formats``: the one place formats are told)."""
    return trajectory_input(path, fmt).format


class TrajectoryReader:
    """The chunks of one trajectory input, an iterator (``read_trajectory`` makes one). Nothing is
    read before the first ``next``; what it learns is kept here as it goes:

    format : ``csv``, ``gpx``, ``pcap`` or ``pcapng`` (as chosen; a capture's own is in ``counts``)
    where : what a chunk's ``line`` counts ("line" or "packet")
    entity_names : the names seen so far (as the last chunk's)
    geographic : a CSV in lon, lat (None before the header is read; True for GPX and captures)
    start : the instant ``t`` counts from where the input has one (ISO times, GPX, a capture), UTC
    time_origin : the same as seconds since 1970 (the chunks'), None where t is relative
    lonlat : the chunks give x = lon, y = lat (deg, WGS 84) and yaw_deg counter-clockwise from true
        east (the local ENU yaw) instead of the terrain's CRS (``export`` to EPSG:4326)
    skipped : what was passed over, by name (a capture's packets and PDUs that are no Entity State,
        a CSV's comment and blank lines); complete once the chunks are exhausted
    counts : a capture's :class:`~tankcd_cli.io.dis.CaptureCounts` (None for other inputs)
    columns : a CSV header's names as written (empty for other formats)
    """

    def __init__(self, path: str, chunk_rows: int = 65536, part: TrajectoryPart | None = None,
                 crs: str | None = None, fmt: str | None = None, convert: bool = True, lonlat: bool = False):
        self.path = path
        self.lonlat = lonlat
        self.time_origin: float | None = None
        self.format = trajectory_format(path, fmt)
        self.where = {"pcap": "packet", "pcapng": "packet", "gpx": "trkpt"}.get(self.format, "line")
        self.chunk_rows = max(1, int(chunk_rows))
        self.part = part
        self.crs = crs
        self.convert = convert and not lonlat
        self.entity_names: tuple = ()
        self.geographic: bool | None = None if self.format == "csv" else True
        self.start: datetime | None = None
        self.skipped: dict = {}
        self.counts = None
        self.columns: tuple = ()
        self._gen = None
        if part is not None and self.format != "csv":
            raise ValueError("only a trajectory CSV is read in parts")

    def __iter__(self) -> "TrajectoryReader":
        return self

    def __next__(self) -> TrajectoryChunk:
        if self._gen is None:
            self._gen = {"csv": self._csv, "gpx": self._gpx}.get(self.format, self._capture)()
        chunk = next(self._gen)
        self.entity_names = chunk.entity_names
        return chunk

    def close(self) -> None:
        if self._gen is not None:
            self._gen.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- CSV ---------------------------------------------------------------------------------------------
    def _csv(self) -> Iterator[TrajectoryChunk]:
        from tankcd_cli.io.trajectory_csv import ByteSource, CsvRows, first_row_time, read_layout, stem_name

        name, fh = open_trajectory_input(self.path)
        try:
            lay = read_layout(fh, name)
            self.geographic = lay.geographic
            self.columns = tuple(lay.header)
            if lay.geographic and self.convert:
                check_crs(self.crs, name)
            part = self.part
            if part is not None:
                first_row_time(fh, lay)
                fh.seek(part.start)
                src = ByteSource(fh, limit=part.end - part.start)
                rows = CsvRows(lay, src, self.chunk_rows, part.line_offset)
                step = part.step_offset
            else:
                rows = CsvRows(lay, ByteSource(fh), self.chunk_rows, lay.header_line)
                step = 0
            names = _Names(() if lay.entity else (stem_name(self.path),))
            order = _Order()
            if not lay.entity and step > 0:
                order.check(np.zeros(1, np.int64), np.array([-np.inf]), np.zeros(1, np.int64), 1)  # a row before
            where_t = {c: j for j, c in enumerate(lay.columns)}
            # no heading column: the track's (not needed to describe the file, unconverted)
            raws = _headed_from_track(rows, lay, self.path) if lay.heading is None and (
                self.convert or self.lonlat) else None
            while True:
                raw = rows.next_rows() if raws is None else next(raws, None)
                self._csv_skipped(lay)
                if raw is None:
                    return
                if self.time_origin is None and lay.time_origin is not None:
                    self.time_origin = lay.time_origin
                    self.start = _EPOCH + (timedelta(seconds=lay.t0[0], microseconds=lay.t0[1] // 1000) if lay.iso
                                           else timedelta(microseconds=round(lay.time_origin * 1e6)))
                if lay.entity:
                    for nm in rows.names[len(names.list):]:
                        names.add(nm)
                chunk, error = self._csv_chunk(raw, lay, names, order, where_t, step)
                if chunk is not None:
                    step += len(chunk)
                    yield chunk
                if error is not None:
                    raise error
        finally:
            if self.path != "-":
                fh.close()

    def _csv_skipped(self, lay) -> None:
        self.skipped = {k: v for k, v in (("comment_lines", lay.comment_lines), ("blank_lines", lay.blank_lines)) if v}

    def _csv_chunk(self, raw, lay, names: _Names, order: _Order, col: dict, step: int):
        n, v = raw.n, raw.values
        error = raw.error
        t = v[0, :n]
        a, b, h = v[1, :n], v[2, :n], v[3, :n]
        lines = raw.line[:n]
        codes = raw.codes[:n] if lay.entity else np.zeros(n, np.int64)
        k = n
        if lay.geographic:
            bad = np.flatnonzero(~((np.abs(a) <= 180.0) & (np.abs(b) <= 90.0)))
            if len(bad):
                k = int(bad[0])
                c, value, limit = ("lon", a[k], 180) if not abs(a[k]) <= 180 else ("lat", b[k], 90)
                error = InputError(lay.name, f"{float(value)!r} is out of range (-{limit} to {limit} degrees)",
                                   where=f"line {lines[k]} column {c}")
        if "gun_deg" in col:
            bad = np.flatnonzero(~(np.abs(v[col["gun_deg"], :k]) <= GUN_LIMIT_DEG))
            if len(bad):
                k = int(bad[0])
                error = InputError(lay.name, f"{float(v[col['gun_deg'], k])!r} is no gun elevation (-{GUN_LIMIT_DEG:g} "
                                             f"to {GUN_LIMIT_DEG:g} degrees)", where=f"line {lines[k]} column gun_deg")
        piece, bad = order.check(codes[:k], t[:k], lines[:k], len(names.list))
        if bad >= 0:
            error = self._order_error(lay.name, lay.entity, names, order, codes[bad], t[bad], lines[bad])
            k = bad
        x, y, yaw = a[:k], b[:k], h[:k]
        compass = lay.heading != "yaw_deg"  # heading_deg, or none: taken from the track as a compass bearing
        still = np.isnan(h[:k])  # no heading from the track: a vehicle that never moves (yaw 0)
        if lay.geographic and self.lonlat:
            yaw = np.where(still, 0.0, 90.0 - h[:k]) if compass else h[:k]
        if lay.geographic and self.convert and k:
            x, y, yaw, bad = geographic_to_crs(a[:k], b[:k], np.where(still, 0.0, h[:k]), compass, self.crs, lay.name)
            yaw[still] = 0.0
            if bad >= 0:
                k = bad
                error = InputError(lay.name, f"lon {float(a[k])!r}, lat {float(b[k])!r} has no place in the terrain's "
                                             "CRS (the projection cannot take it)", where=f"line {lines[k]}")
                x, y, yaw = x[:k], y[:k], yaw[:k]
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
                                lay.entity, "line", self.time_origin)
        return chunk, error

    @staticmethod
    def _order_error(name, has_entity, names, order, code, t, line):
        prev = float(order.last_t[code])
        if not has_entity:
            return InputError(name, f"time goes back ({float(t)!r} after {prev!r}); t must be non-decreasing",
                              where=f"line {line} column t")
        return InputError(name, f"entity {names.list[code]!r}: time goes back ({float(t)!r} after {prev!r} on "
                                f"line {int(order.last_line[code])}); each entity's t must be non-decreasing",
                          where=f"line {line}")

    # -- GPX ---------------------------------------------------------------------------------------------
    def _gpx(self) -> Iterator[TrajectoryChunk]:
        from tankcd_cli.io.gpx import read_gpx

        if self.convert:
            check_crs(self.crs, self.path)
        g = read_gpx(self.path)
        self.start = g.start
        self.time_origin = g.origin
        names = _Names(_track_names(g.track_names))
        n = len(g)
        codes = g.track.astype(np.int64)
        piece_start = np.r_[True, g.piece[1:] != g.piece[:-1]]
        order = _Order()
        _, bad = order.check(codes, g.t, g.line, len(names.list))
        heading = _fill_by_entity(g.heading, codes)
        ends = n if bad < 0 else bad
        # the tracks come one after another in the file, not in time order: as one chunk (the file is
        # in memory already) the checks between vehicles see every track's motion at every time
        step = self.chunk_rows if len(names.list) <= 1 else max(ends, 1)
        for lo in range(0, ends, step):
            hi = min(lo + step, ends)
            if self.convert:
                from tankcd_cli.io.geodesy import to_terrain_crs

                x, y, yaw = to_terrain_crs(g.lon[lo:hi], g.lat[lo:hi], self.crs, heading=heading[lo:hi],
                                           source=self.path)
                yaw = np.degrees(yaw)
                yaw[np.isnan(heading[lo:hi])] = 0.0  # a track that never moves: no heading to give
            elif self.lonlat:  # the local ENU yaw
                x, y, yaw = g.lon[lo:hi], g.lat[lo:hi], np.nan_to_num(90.0 - np.degrees(heading[lo:hi]), nan=0.0)
            else:
                x, y, yaw = g.lon[lo:hi], g.lat[lo:hi], np.degrees(heading[lo:hi])
            top = int(codes[hi - 1]) + 1  # tracks come in file order: the names seen so far
            zeros = np.zeros(hi - lo)
            point = np.arange(lo + 1, hi + 1)  # a track point by its number from 1 (its line says little in
            # a file written on one line, as many are)
            yield TrajectoryChunk(np.arange(lo, hi), lo + 1, g.t[lo:hi], x, y, yaw, zeros, zeros, False,
                                  point, codes[lo:hi], tuple(names.list[:top]), piece_start[lo:hi], True,
                                  "trkpt", self.time_origin)
        if bad >= 0:
            k = bad
            prev = order.last_t[codes[k]]
            raise InputError(self.path, f"track {names.list[codes[k]]!r}: time goes back ({float(g.t[k])!r} s after "
                                        f"{float(prev)!r} s at line {int(order.last_line[codes[k]])}): a track's "
                                        "segments must follow one another in time",
                             where=f"trkpt {k + 1} (line {int(g.line[k])})")

    # -- DIS captures --------------------------------------------------------------------------------------
    def _capture(self) -> Iterator[TrajectoryChunk]:
        from tankcd_cli.io.dis import DisCapture

        cap = DisCapture(self.path, block_pdus=self.chunk_rows)
        if self.convert:
            check_crs(self.crs, cap.name)
        self.counts = cap.counts
        state = _CaptureState(cap.name)
        step = 0
        for states in cap.blocks():
            if self.start is None and cap._first_sec[0] >= 0:
                self.start = _EPOCH + timedelta(seconds=int(cap._first_sec[0]), microseconds=round(
                    float(cap._first_frac[0]) * 1e6))
                self.time_origin = float(cap._first_sec[0]) + float(cap._first_frac[0])
            cap.counts.duplicates = state.duplicates
            self.skipped = cap.counts.skipped()
            for chunk in state.take(self, states, step):
                step += len(chunk)
                yield chunk
        for chunk in state.flush(self, step):
            step += len(chunk)
            yield chunk
        cap.counts.duplicates = state.duplicates
        self.counts = cap.counts
        self.skipped = cap.counts.skipped()
        _warn_capture(cap.name, cap.counts, state)


def _warn_capture(name: str, counts, state: "_CaptureState") -> None:
    """The set-up warnings of a capture read to its end: packets its snap length cut, duplicates dropped."""
    from tankcd_cli.errors import warn

    if counts.truncated:
        lost = f"; {counts.pdus_cut:,} PDUs in them cut short and not read" if counts.pdus_cut else \
            "; every Entity State PDU in them was whole and is read"
        warn(name, f"{counts.truncated:,} packets were captured shorter than they were sent (the capture's snap "
                   f"length){lost}")
    if state.duplicates:
        warn(name, f"{state.duplicates:,} duplicate Entity State PDUs dropped (each repeats its entity's row before "
                   f"it exactly: the same capture time, location, orientation, turret and gun; first at packet "
                   f"{state.first_duplicate}): a capture taken on two interfaces, or merged with itself?")


class _CaptureState:
    """A capture's rows on their way out, in an order that does not depend on how the capture is cut
    into blocks (docs/formats.md, "DIS captures"):

    each packet P gets the key k_P = max(t_P, L_P - W), L_P the latest capture time of the packets up
    to P (in capture order), W = ``REORDER_WINDOW``; the rows go out stably sorted by k. A packet at
    most W behind the latest before it keeps k = t (put back in time order); one further behind goes
    where the window had reached (k = L_P - W), and its entity's time going back there is the error.

    Proof that streaming gives that order: every packet Q after the ones read so far has k_Q >= L_Q -
    W >= L - W (L the latest so far; L is non-decreasing), and goes after every earlier packet of
    equal k (the sort is stable); so the rows read with k < L - W are a prefix of the whole capture's
    order, whatever the blocks. Then the rows go through each entity's time check, the duplicates
    (a row equal to its entity's row before it in time, position, orientation, turret and gun) are
    dropped and counted, the turret and gun carried where a PDU has none, and the rows cut into chunks."""

    def __init__(self, name: str = ""):
        self.name = name
        self.names = _Names()
        self.interner = None
        self.order = _Order()
        self.pending: dict | None = None
        self.latest = -np.inf
        self.latest_packet = 0
        self.last_turret = np.zeros(16)
        self.last_gun = np.zeros(16)
        self.last_state = np.full((16, 9), np.nan)  # each entity's last row: t, location, orientation, parts
        self.duplicates = 0
        self.first_duplicate = 0
        self.has_turret = False

    def _codes(self, ids: np.ndarray) -> np.ndarray:
        """Codes of (N, 3) uint16 entity ids, through the compiled interner over their 6 bytes each."""
        from tankcd_cli.io.csv_kernels import Interner

        if self.interner is None:
            self.interner = Interner()
        n = len(ids)
        raw = np.ascontiguousarray(ids, dtype=np.uint16).view(np.uint8).reshape(-1)
        at = np.arange(0, 6 * n, 6, dtype=np.int64)
        codes, first, _ = self.interner.codes(raw, np.column_stack([at, at + 6]), n)
        for k in range(first, len(self.interner)):
            site, app, ent = np.frombuffer(self.interner.name(k), np.uint16).tolist()
            self.names.add(f"{site}:{app}:{ent}")  # the same order: the same codes
        return codes

    def take(self, reader: TrajectoryReader, states, step: int):
        n = len(states)
        if not n:
            return
        if reader.convert:
            from tankcd_cli.io.dis import trajectory_columns

            cols = trajectory_columns(states, reader.crs, source=self.name)
            block = {"t": states.t, "x": cols["x"], "y": cols["y"], "yaw_deg": cols["yaw_deg"],
                     "turret_deg": cols["turret_deg"], "gun_deg": cols["gun_deg"]}
        elif reader.lonlat:
            from tankcd_cli.io.dis import articulation_angles
            from tankcd_cli.io.geodesy import dis_orientation_to_enu, ecef_to_geodetic

            lon, lat, _ = ecef_to_geodetic(states.location)
            o = np.asarray(states.orientation, dtype=np.float64).reshape(-1, 3)
            yaw, _, _ = dis_orientation_to_enu(o[:, 0], o[:, 1], o[:, 2], lon, lat)
            turret, gun = articulation_angles(states.turret_azimuth, states.gun_elevation)
            block = {"t": states.t, "x": lon, "y": lat, "yaw_deg": np.degrees(yaw), "turret_deg": np.degrees(turret),
                     "gun_deg": np.degrees(gun)}
        else:
            from tankcd_cli.io.dis import articulation_angles

            turret, gun = articulation_angles(states.turret_azimuth, states.gun_elevation)
            nan = np.full(n, np.nan)
            block = {"t": states.t, "x": nan, "y": nan, "yaw_deg": nan, "turret_deg": np.degrees(turret),
                     "gun_deg": np.degrees(gun)}
        block["packet"] = states.packet
        block["code"] = self._codes(states.entity_id)
        block["state"] = np.column_stack([states.t, states.location, states.orientation, states.turret_azimuth,
                                          states.gun_elevation])
        # the latest capture time up to each packet (and that packet, for messages), across blocks
        t = states.t
        latest = np.maximum.accumulate(np.r_[self.latest, t])[1:]
        new_max = np.r_[self.latest, latest[:-1]] < t
        at = np.maximum.accumulate(np.where(new_max, np.arange(1, n + 1), 0))
        block["latest"] = latest
        block["latest_packet"] = np.where(at > 0, states.packet[np.maximum(at - 1, 0)], self.latest_packet)
        block["key"] = np.maximum(t, latest - REORDER_WINDOW)
        self.latest, self.latest_packet = float(latest[-1]), int(block["latest_packet"][-1])
        if self.pending is not None:
            block = {k: np.concatenate([self.pending[k], v]) for k, v in block.items()}
        key = block["key"]
        if np.any(key[1:] < key[:-1]):
            idx = np.argsort(key, kind="stable")
            block = {k: v[idx] for k, v in block.items()}
            key = block["key"]
        cut = int(np.searchsorted(key, self.latest - REORDER_WINDOW, side="left"))
        self.pending = {k: v[cut:] for k, v in block.items()}
        yield from self._emit(reader, {k: v[:cut] for k, v in block.items()}, step)

    def flush(self, reader: TrajectoryReader, step: int):
        if self.pending is not None:
            block, self.pending = self.pending, None
            yield from self._emit(reader, block, step)

    def _grow(self, ncodes: int) -> None:
        if len(self.last_turret) < ncodes:
            grow = max(ncodes, 2 * len(self.last_turret)) - len(self.last_turret)
            self.last_turret = np.r_[self.last_turret, np.zeros(grow)]
            self.last_gun = np.r_[self.last_gun, np.zeros(grow)]
            self.last_state = np.vstack([self.last_state, np.full((grow, 9), np.nan)])

    def _duplicates(self, block: dict) -> np.ndarray | None:
        """(N,) bool the rows equal to their entity's row before them (t, location, orientation, turret and
        gun as decoded; NaN equal to NaN), counted; None for none."""
        codes, state = block["code"], block["state"]
        n = len(codes)
        if n == 0:
            return None
        order = np.argsort(codes, kind="stable")  # each entity's rows together, in order
        c = codes[order]
        first = np.r_[True, c[1:] != c[:-1]]
        prev = np.empty_like(state)
        prev[1:] = state[order[:-1]]
        prev[first] = self.last_state[c[first]]
        cur = state[order]
        same = ((cur == prev) | (np.isnan(cur) & np.isnan(prev))).all(axis=1)
        last = np.r_[c[1:] != c[:-1], True]
        self.last_state[c[last]] = cur[last]
        if not same.any():
            return None
        drop = np.zeros(n, bool)
        drop[order[same]] = True
        if not self.duplicates:
            self.first_duplicate = int(block["packet"][np.flatnonzero(drop)[0]])
        self.duplicates += int(drop.sum())
        return drop

    def _emit(self, reader: TrajectoryReader, block: dict, step: int):
        n = len(block["t"])
        if not n:
            return
        codes = block["code"]
        ncodes = len(self.names.list)
        self._grow(ncodes)
        piece, bad = self.order.check(codes, block["t"], block["packet"], ncodes)
        k = n if bad < 0 else bad
        error = self._order_error(block, bad) if bad >= 0 else None
        far = np.flatnonzero(np.abs(block["gun_deg"][:k]) > GUN_LIMIT_DEG)  # NaN: no gun record, kept
        if len(far):
            k = bad = int(far[0])
            error = InputError(self.name, f"Entity State PDU's gun elevation {float(block['gun_deg'][k]):.6g} deg is "
                                          f"no elevation (beyond +-{GUN_LIMIT_DEG:g} deg)",
                               where=f"packet {int(block['packet'][k])}")
        if bad >= 0:
            block = {key: v[:k] for key, v in block.items()}
            piece = piece[:k]
        drop = self._duplicates(block)
        if drop is not None:  # a duplicate is never its entity's first row: the pieces stay as they are
            block = {key: v[~drop] for key, v in block.items()}
            piece = piece[~drop]
        codes = block["code"]
        k = len(codes)
        self.has_turret = self.has_turret or bool(np.isfinite(block["turret_deg"]).any()
                                                  or np.isfinite(block["gun_deg"]).any())
        turret = _carry(block["turret_deg"], codes, self.last_turret)
        gun = _carry(block["gun_deg"], codes, self.last_gun)
        names = self.names.tuple()
        for lo in range(0, k, reader.chunk_rows):
            hi = min(lo + reader.chunk_rows, k)
            yield TrajectoryChunk(np.arange(step + lo, step + hi), int(block["packet"][lo]), block["t"][lo:hi],
                                  block["x"][lo:hi], block["y"][lo:hi], block["yaw_deg"][lo:hi], turret[lo:hi],
                                  gun[lo:hi], self.has_turret, block["packet"][lo:hi], codes[lo:hi], names,
                                  piece[lo:hi], True, "packet", reader.time_origin)
        if error is not None:
            raise error

    def _order_error(self, block: dict, bad: int) -> InputError:
        code = int(block["code"][bad])
        prev = float(self.order.last_t[code])
        t = float(block["t"][bad])
        behind = float(block["latest"][bad]) - t
        return InputError(self.name, f"entity {self.names.list[code]!r}: capture time goes back {prev - t:.6f} s (t "
                                     f"{t!r} after {prev!r} at packet {int(self.order.last_line[code])}): the packet "
                                     f"is {behind:.6f} s behind the capture's latest time (packet "
                                     f"{int(block['latest_packet'][bad])}), more than the {REORDER_WINDOW:g} s this "
                                     "reader puts back in order; sort the capture by time first (Wireshark's "
                                     "reordercap does)",
                          where=f"packet {int(block['packet'][bad])}")


def _headed_from_track(rows, lay, path: str):
    """The raw rows of a lon, lat CSV without a heading column, each given the compass heading of its
    track as a GPX track's points are (``io.gpx.track_headings``: the azimuth to the same entity's
    next row; a row that does not move keeps the heading before it), in degrees in the heading
    column (NaN where the entity never moves). The heading needs the rows after a row, so the file
    is read whole first, as a GPX file is (memory follows the file; a warning says so)."""
    from tankcd_cli.errors import warn
    from tankcd_cli.io.gpx import track_headings

    raws = []
    while True:
        raw = rows.next_rows()
        if raw is None:
            break
        raws.append(raw)
        if raw.error is not None:
            break
    n = sum(r.n for r in raws)
    whose = "its entity's" if lay.entity else "the track's"
    if n:
        warn(lay.name, f"no heading column (heading_deg or yaw_deg) beside lon, lat: each row heads toward {whose} "
                       f"next row, as a GPX track's points do (the file is read whole for it: {n:,} rows)")
        lon = np.concatenate([r.values[1, :r.n] for r in raws])
        lat = np.concatenate([r.values[2, :r.n] for r in raws])
        codes = np.concatenate([r.codes[:r.n] for r in raws]) if lay.entity else np.zeros(n, np.int64)
        order = np.argsort(codes, kind="stable")  # each entity's rows together, in file order
        ok = (np.abs(lon) <= 180.0) & (np.abs(lat) <= 90.0)  # the rows the range check refuses: no heading
        heading = np.full(n, np.nan)
        good = order[ok[order]]
        heading[good] = np.degrees(track_headings(lon[good], lat[good], codes[good]))
        at = 0
        for r in raws:
            r.values[3, :r.n] = heading[at:at + r.n]
            at += r.n
    yield from raws


def _carry(values: np.ndarray, codes: np.ndarray, last: np.ndarray) -> np.ndarray:
    """NaN values replaced by the same entity's value before them (``last[code]`` before its first row in
    these; ``last`` updated to each entity's last value)."""
    from tankcd_cli.io.csv_kernels import carry

    out = np.array(values, dtype=np.float64)
    carry(np.ascontiguousarray(codes, dtype=np.int64), out, last)
    return out


def _fill_by_entity(values: np.ndarray, codes: np.ndarray) -> np.ndarray:
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


def _track_names(raw: list) -> list:
    """GPX track names as entity ids: a track's name without commas, quotes or control characters
    ('_' instead), ``trackK`` (K from 1) for a track without one; a name already taken gains ``_2``, ``_3``..."""
    import re

    names, taken = [], set()
    for k, name in enumerate(raw):
        base = re.sub(r"[,\"'\x00-\x1f\x7f]", "_", name).strip() or f"track{k + 1}"
        got, j = base, 2
        while got in taken:
            got, j = f"{base}_{j}", j + 1
        taken.add(got)
        names.append(got)
    return names


def check_crs(crs: str | None, source: str) -> None:
    """Refuse (InputError naming ``source``) a terrain without a CRS, or with one pyproj cannot read or that is
    not projected, before any row is read."""
    from tankcd_cli.io.geodesy import project

    project(np.zeros(0), np.zeros(0), crs or "", source=source)


def geographic_to_crs(lon, lat, heading_deg, compass: bool, crs: str, source: str):
    """lon, lat, heading (deg) -> x, y, yaw_deg in the terrain's CRS, and the first row that has no place
    there (-1 for none)."""
    from tankcd_cli.io.geodesy import to_terrain_crs

    h = np.radians(heading_deg)
    x, y, yaw = to_terrain_crs(lon, lat, crs, heading=h if compass else None, enu_yaw=None if compass else h,
                               source=source)
    yaw = np.degrees(yaw)
    bad = np.flatnonzero(~(np.isfinite(x) & np.isfinite(y) & np.isfinite(yaw)))
    return x, y, yaw, (int(bad[0]) if len(bad) else -1)


def read_trajectory(path: str, chunk_rows: int = 65536, part: TrajectoryPart | None = None, crs: str | None = None,
                    fmt: str | None = None) -> TrajectoryReader:
    """The chunks of a trajectory input in its order (only ``part``'s rows of a CSV, if given: steps and
    line numbers stay those of the whole file), as a :class:`TrajectoryReader` (an iterator).

    ``crs``: the terrain's CRS (WKT, or anything pyproj takes; None or empty: the terrain has none).
    Geographic inputs (a CSV in lon, lat; GPX; DIS captures) are converted to it, and refused
    (InputError naming the file) without one. ``fmt``: csv, gpx, pcap or pcapng (default: by suffix)."""
    return TrajectoryReader(path, chunk_rows, part, crs, fmt)


# -- parts of a CSV ------------------------------------------------------------------------------------------
def _csv_layout(path: str):
    from tankcd_cli.io.trajectory_csv import read_layout

    name, fh = open_trajectory_input(path)
    with fh:
        return read_layout(fh, name)


def has_entity_column(path: str) -> bool:
    """Whether a trajectory CSV's header has an ``entity`` column (False for other formats, and for a
    CSV whose header cannot be read: its replay will say what is wrong)."""
    if trajectory_format(path) != "csv":
        return False
    try:
        return bool(_csv_layout(path).entity)
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
    lay = _csv_layout(path)
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


def _lead_rows_by_entity(path: str, part: TrajectoryPart, lay, crs) -> TrajectoryChunk | None:
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
    if trajectory_format(path) != "csv":
        raise InputError(path, "only a trajectory CSV is cut into parts")
    parts: list[TrajectoryPart] = []
    try:
        lay = _csv_layout(path)
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


# -- what an input holds (for ``info``) ------------------------------------------------------------------------
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

    format : csv, gpx, pcap or pcapng; coordinates : ``projected`` (x, y in the terrain's CRS),
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
    coords = {"gpx": "geographic", "pcap": "ecef", "pcapng": "ecef"}.get(
        reader.format, "geographic" if reader.geographic else "projected")
    entities = tuple(EntitySpan(names[k], int(rows[k]), float(t_first[k]), float(t_last[k]), int(l_first[k]),
                                int(l_last[k]), int(pieces[k])) for k in range(len(names)))
    columns = reader.columns
    total = int(rows.sum())
    return TrajectoryInfo(path=path, format=reader.format, coordinates=coords, where=reader.where, rows=total,
                          t_first=float(np.nanmin(t_first)) if total else float("nan"),
                          t_last=float(np.nanmax(t_last)) if total else float("nan"), start=reader.start,
                          has_entity=has_entity, has_turret=has_turret, entities=entities,
                          skipped=dict(reader.skipped), columns=columns, time_origin=utc_text(reader.time_origin))


# -- export ------------------------------------------------------------------------------------------------------
_EXPORT_DECIMALS = np.array([9, 6, 6, 9, 9, 9])  # t (ns), x, y (um), angles (1e-9 deg)
_EXPORT_LONLAT_DECIMALS = np.array([9, 10, 10, 9, 9, 9])  # lon, lat to 1e-10 deg (about 11 um)
EXPORT_NO_CRS = ("a geographic trajectory (lon, lat; GPX; a DIS capture) is exported in a CRS: give --terrain, "
                 "--scene or --crs (EPSG:32633, or EPSG:4326 for lon, lat)")


def utc_text(origin: float | None) -> str | None:
    """Seconds since 1970 -> ISO 8601 UTC (``2026-05-04T10:00:00.05Z``), None for None. The fraction is
    the float's shortest decimal (``repr``'s: 7 digits at most at today's dates), so that
    ``trajectory_csv.iso_seconds`` and ``epoch_seconds`` read it back into the same float64."""
    from decimal import ROUND_FLOOR, Decimal

    if origin is None:
        return None
    exact = Decimal(repr(float(origin)))
    if exact.as_tuple().exponent < -9:  # before 1973 a float holds more than nanoseconds: to 1 ns
        exact = exact.quantize(Decimal(1).scaleb(-9))
    whole = int(exact.to_integral_value(rounding=ROUND_FLOOR))
    frac = format(exact - whole, "f")  # "0.05", "0"
    text = (_EPOCH + timedelta(seconds=whole)).strftime("%Y-%m-%dT%H:%M:%S")
    digits = frac.partition(".")[2].rstrip("0")
    return text + (f".{digits}" if digits else "") + "Z"


def is_wgs84(crs: str | None) -> bool:
    """``crs`` is WGS 84 longitude and latitude (EPSG:4326, in either axis order)."""
    if not crs:
        return False
    from pyproj import CRS
    from pyproj.exceptions import CRSError

    try:
        given = CRS.from_user_input(crs)
    except CRSError:
        return False
    return given.is_geographic and given.equals(CRS.from_epsg(4326), ignore_axis_order=True)


class _TurretLate(Exception):
    """A capture's turret and gun angles first seen after the export's header was written without them."""


def export_trajectory(path: str, out: str, crs: str | None = None, fmt: str | None = None,
                      chunk_rows: int = 65536) -> dict:
    """Write any trajectory input as the trajectory CSV tankcd reads: ``t,entity,x,y,yaw_deg`` in the
    terrain's CRS (``crs`` as ``read_trajectory`` takes it), or with ``crs`` EPSG:4326
    ``t,entity,lon,lat,heading_deg`` (WGS 84 degrees, a compass heading: the geographic CSV), and
    ``turret_deg,gun_deg`` where the input has those angles; rows in the reader's order, t to 1 ns,
    positions to 1 um (lon, lat to 1e-10 deg), angles to 1e-9 deg. Where the input has an absolute
    clock a ``# time_origin: ...Z`` comment before the header keeps it (read back: the same origin and
    the same t). ``out``: a file (written beside and renamed when complete: an error leaves nothing)
    or '-'. The first chunk is read before anything is written: a geographic input without a CRS
    (InputError naming the options that give one) or a bad first row writes nothing. Returns
    {"rows", "entities", "skipped"}."""
    from tankcd_cli.io.atomic import output_text
    from tankcd_cli.io.geodesy import NO_CRS

    lonlat = is_wgs84(crs)
    turret = None  # the columns: from the first chunk (a capture's later turret: again, with them)
    while True:
        reader = TrajectoryReader(path, chunk_rows, None, None if lonlat else crs, fmt, lonlat=lonlat)
        try:
            first = next(reader, None)
        except InputError as exc:
            if exc.what == NO_CRS:  # no CRS was given: name the options that give one
                raise InputError(exc.source, EXPORT_NO_CRS) from None
            raise
        if lonlat and not reader.geographic:
            raise InputError(path, "x, y in metres are in no CRS tankcd knows: export them to lon, lat from a "
                                   "geographic input only (or give --crs of a projected CRS: written as they are)")
        if turret is None:
            turret = bool(first is not None and first.has_turret)
        columns = ("t", "entity") + (("lon", "lat", "heading_deg") if lonlat else ("x", "y", "yaw_deg"))
        columns += ("turret_deg", "gun_deg") if turret else ()
        rows = 0
        try:
            with output_text(out, ".csv", newline="") as fh:
                if reader.time_origin is not None:
                    fh.write(f"# time_origin: {utc_text(reader.time_origin)}\n")
                fh.write(",".join(columns) + "\n")
                for chunk in ([first] if first is not None else []):
                    fh.write(_export_text(chunk, lonlat, turret))
                    rows += len(chunk)
                for chunk in reader:
                    if chunk.has_turret and not turret:
                        if out == "-":
                            from tankcd_cli.errors import warn

                            warn(path, f"turret and gun angles from {reader.where} {int(chunk.line[0])} on: the "
                                       "export's columns, written before, have none (export to a file to keep them)")
                            turret = False
                        else:
                            raise _TurretLate
                    fh.write(_export_text(chunk, lonlat, turret))
                    rows += len(chunk)
        except _TurretLate:
            reader.close()
            turret = True
            continue
        return {"rows": rows, "entities": len(reader.entity_names), "skipped": dict(reader.skipped)}


def _export_text(chunk: TrajectoryChunk, lonlat: bool = False, turret: bool = True) -> str:
    from tankcd_cli.io.fixed_text import table_text

    heading = np.mod(90.0 - chunk.yaw_deg, 360.0) if lonlat else chunk.yaw_deg  # lonlat: from ENU yaw to compass
    cols = [chunk.t, chunk.x, chunk.y, heading] + ([chunk.turret_deg, chunk.gun_deg] if turret else [])
    numbers = np.column_stack(cols)
    decimals = (_EXPORT_LONLAT_DECIMALS if lonlat else _EXPORT_DECIMALS)[:len(cols)]
    names = list(chunk.entity_names)
    text = None
    if all(n.isascii() for n in names):
        kinds = np.array([0, 1] + [0] * (len(cols) - 1))
        index = np.array([0, 0] + list(range(1, len(cols))))
        text = table_text(numbers, decimals, chunk.entity.reshape(-1, 1), names, kinds, index)
    if text is None:  # a name beyond ASCII, or a number too large for fixed point
        label = np.asarray(names, dtype=object)[chunk.entity]
        forms = ["{:.%df}" % d for d in decimals]
        text = "".join(",".join([forms[0].format(r[0]), e] + [f.format(v) for f, v in zip(forms[1:], r[1:])]) + "\n"
                       for r, e in zip(numbers.tolist(), label.tolist()))
    return text


# -- several files as one exercise --------------------------------------------------------------------------
def merged_trajectories(paths: list, chunk_rows: int = 65536, crs: str | None = None):
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
    import dataclasses
    import os

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
