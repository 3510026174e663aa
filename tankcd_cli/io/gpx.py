"""GPX tracks: the track points of every track and segment, with times, and the heading along each segment.

The file is read by a streaming XML parser (expat, which ElementTree's iterparse runs on, used
directly: no element tree is built, so memory holds only the points' numbers, and each track
point's line number comes from the parser at its start tag). GPX 1.1 and 1.0 namespaces, or none.
Only ``trk/trkseg/trkpt`` is read (``lat``, ``lon`` attributes; ``time``, ``ele`` children; the
track's ``name``); waypoints, routes and extensions are passed over.

Every (track, segment) is a piece of motion of its own: a caller moves a vehicle along a piece's
points and never between the last point of one piece and the first of the next.
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass
from datetime import datetime, timezone

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.input_bytes import open_trajectory_input

GPX_NAMESPACES = ("http://www.topografix.com/GPX/1/1", "http://www.topografix.com/GPX/1/0", "")
STILL = 0.05  # m: a step shorter than this does not give a heading
_EPOCH = datetime(1970, 1, 1, tzinfo=timezone.utc)


@dataclass
class GpxTrack:
    """N track points in file order.

    track : (N,) int64 the track's index in the file (from 0); ``track_names[track]`` its name ('' if none)
    segment : (N,) int64 the segment's index within its track (from 0)
    piece : (N,) int64 the (track, segment)'s index over the file (from 0): each piece its own motion
    lon, lat : (N,) float64 deg (WGS 84); ele : (N,) float64 m (NaN where the point has none)
    t : (N,) float64 s since the first point of the file (the file's order: a later track may start
        earlier, with t < 0)
    heading : (N,) float64 rad, true (compass) heading, clockwise from true north (see ``track_headings``)
    line : (N,) int64 the line of each point's ``<trkpt`` tag
    start : the first point's time (UTC)
    origin : the same as seconds since 1970 (the instant of t = 0)
    """

    track: np.ndarray
    track_names: list
    segment: np.ndarray
    piece: np.ndarray
    lon: np.ndarray
    lat: np.ndarray
    ele: np.ndarray
    t: np.ndarray
    heading: np.ndarray
    line: np.ndarray
    start: datetime
    origin: float | None = None

    def __len__(self) -> int:
        return len(self.t)

    @property
    def track_name(self) -> np.ndarray:
        """(N,) str: each point's track name."""
        return np.array(self.track_names, dtype=str)[self.track] if self.track_names else np.zeros(0, str)


def track_headings(lon, lat, piece, still: float = STILL) -> np.ndarray:
    """True headings (N,) rad in [0, 2 pi) along tracks: at each point the azimuth (pyproj.Geod.inv on
    WGS 84) to the next point of the same piece. A point less than ``still`` m from the next keeps the
    heading before it; the last point of a piece keeps the one before it; points of a piece that has
    not moved yet take its first real heading. A piece that never moves has NaN (no heading to give:
    the caller picks one).

    lon, lat : (N,) deg; piece : (N,) int, equal for the points of one piece, pieces contiguous.
    """
    from pyproj import Geod

    lon = np.asarray(lon, dtype=np.float64)
    lat = np.asarray(lat, dtype=np.float64)
    piece = np.asarray(piece)
    n = len(lon)
    heading = np.full(n, np.nan)
    if n < 2:
        return heading
    az, _, dist = Geod(ellps="WGS84").inv(lon[:-1], lat[:-1], lon[1:], lat[1:])
    moves = (piece[:-1] == piece[1:]) & (dist >= still)
    idx = np.arange(n)
    known = np.zeros(n, bool)
    known[:-1] = moves
    heading[:-1][moves] = np.mod(np.radians(az[moves]), 2 * np.pi)
    start = np.r_[0, np.flatnonzero(piece[1:] != piece[:-1]) + 1]  # first point of each piece
    first = np.repeat(start, np.diff(np.r_[start, n]))
    last = np.repeat(np.r_[start[1:], n] - 1, np.diff(np.r_[start, n]))
    before = np.maximum.accumulate(np.where(known, idx, -1))  # the latest known point at or before
    after = np.minimum.accumulate(np.where(known, idx, n)[::-1])[::-1]  # the earliest at or after
    use = np.where(before >= first, before, np.where(after <= last, after, -1))
    out = np.full(n, np.nan)
    ok = use >= 0
    out[ok] = heading[use[ok]]
    return out


def read_gpx(path: str) -> GpxTrack:
    """Every track point of a GPX file (see :class:`GpxTrack`). Raises InputError naming the file and
    the point (``trkpt K (line L)``) for a point without a time or with a bad lat or lon, a time going
    back within a segment, malformed XML, or a file without track points."""
    import xml.parsers.expat

    points = _Points(path)
    parser = xml.parsers.expat.ParserCreate(namespace_separator=" ")
    parser.buffer_text = True
    points.parser = parser
    parser.StartElementHandler = points.start
    parser.EndElementHandler = points.end
    parser.CharacterDataHandler = points.text
    try:
        name, fh = open_trajectory_input(path)  # '-' standard input; gzip decompressed as it is read
        with fh:
            parser.ParseFile(fh)
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None
    except xml.parsers.expat.ExpatError as exc:
        raise InputError(path, f"not well-formed XML ({xml.parsers.expat.ErrorString(exc.code)}, column "
                               f"{exc.offset + 1})", where=f"line {exc.lineno}") from None
    return points.finish()


class _Points:
    """The expat handlers: the track points' numbers, gathered into arrays."""

    def __init__(self, path: str):
        self.path = path
        self.parser = None
        self.stack: list = []  # (local name, in a GPX namespace) of the open elements
        self.track_names: list = []
        self.track = array("q")
        self.segment = array("q")
        self.lon = array("d")
        self.lat = array("d")
        self.ele = array("d")
        self.time = array("q")  # microseconds since 1970 (UTC)
        self.line = array("q")
        self.n_tracks = 0
        self.n_segments = 0
        self.point = None  # the open trkpt: [lon, lat, ele, time, line]
        self.chars: list = []

    def _where(self, k=None, line=None) -> str:
        k = len(self.lon) + 1 if k is None else k
        return f"trkpt {k} (line {self.point[4] if line is None else line})"

    def start(self, name, attrs):
        uri, _, local = name.rpartition(" ")
        gpx = uri in GPX_NAMESPACES
        parent = self.stack[-1] if self.stack else (None, False)
        self.stack.append((local, gpx))
        if not gpx:
            return
        if local == "trk" and parent == ("gpx", True):
            self.n_tracks += 1
            self.n_segments = 0
            self.track_names.append("")
        elif local == "trkseg" and parent == ("trk", True):
            self.n_segments += 1
        elif local == "trkpt" and parent == ("trkseg", True):
            self.point = [None, None, np.nan, None, self.parser.CurrentLineNumber]
            lat, lon = attrs.get("lat"), attrs.get("lon")
            self.point[0] = self._coordinate(lon, "lon", 180.0)
            self.point[1] = self._coordinate(lat, "lat", 90.0)
        elif local in ("time", "ele", "name"):
            self.chars = []

    def _coordinate(self, text, what, limit):
        if text is None:
            raise InputError(self.path, f"track point has no {what} attribute", where=self._where())
        try:
            value = float(text)
        except ValueError:
            raise InputError(self.path, f"{what} {text!r} is not a number", where=self._where()) from None
        if not -limit <= value <= limit:  # NaN fails too
            raise InputError(self.path, f"{what} {text} is out of range (-{limit:g} to {limit:g} degrees)",
                             where=self._where())
        return value

    def text(self, data):
        self.chars.append(data)

    def end(self, name):
        local, gpx = self.stack.pop()
        if not gpx:
            return
        parent = self.stack[-1] if self.stack else (None, False)
        if local == "trkpt" and parent == ("trkseg", True):
            lon, lat, ele, time, line = self.point
            if time is None:
                raise InputError(self.path, "track point has no time (tankcd needs the time of every point)",
                                 where=self._where())
            self.track.append(self.n_tracks - 1)
            self.segment.append(self.n_segments - 1)
            self.lon.append(lon)
            self.lat.append(lat)
            self.ele.append(ele)
            self.time.append(time)
            self.line.append(line)
            self.point = None
        elif self.point is not None and parent == ("trkpt", True) and local in ("time", "ele"):
            text = "".join(self.chars).strip()
            if local == "time":
                self.point[3] = self._time(text)
            else:
                try:
                    self.point[2] = float(text)
                except ValueError:
                    raise InputError(self.path, f"ele {text!r} is not a number", where=self._where()) from None
        elif local == "name" and parent == ("trk", True):
            self.track_names[-1] = "".join(self.chars).strip()

    def _time(self, text: str) -> int:
        try:
            when = datetime.fromisoformat(text)
        except ValueError:
            raise InputError(self.path, f"time {text!r} is not an ISO 8601 date and time "
                                        "(such as 2026-05-04T10:00:00.25Z)", where=self._where()) from None
        if when.tzinfo is None:  # GPX times are UTC
            when = when.replace(tzinfo=timezone.utc)
        delta = when - _EPOCH
        return (delta.days * 86400 + delta.seconds) * 1_000_000 + delta.microseconds

    def finish(self) -> GpxTrack:
        n = len(self.lon)
        if n == 0:
            raise InputError(self.path, "no track points (trk/trkseg/trkpt) in this GPX file")
        track = np.frombuffer(self.track, np.int64).copy()
        segment = np.frombuffer(self.segment, np.int64).copy()
        change = np.r_[True, (track[1:] != track[:-1]) | (segment[1:] != segment[:-1])]
        piece = np.cumsum(change) - 1
        micros = np.frombuffer(self.time, np.int64)
        back = np.flatnonzero(~change[1:] & (micros[1:] < micros[:-1])) + 1
        line = np.frombuffer(self.line, np.int64).copy()
        if len(back):
            k = back[0]
            raise InputError(self.path, f"time goes back within a segment ({(micros[k] - micros[k - 1]) / 1e6:g} s "
                                        f"after the point before it)", where=self._where(k + 1, line[k]))
        lon = np.frombuffer(self.lon, np.float64).copy()
        lat = np.frombuffer(self.lat, np.float64).copy()
        t = (micros - micros[0]) / 1e6
        start = datetime.fromtimestamp(micros[0] // 1_000_000, timezone.utc).replace(
            microsecond=int(micros[0] % 1_000_000))
        return GpxTrack(track=track, track_names=list(self.track_names), segment=segment, piece=piece, lon=lon,
                        lat=lat, ele=np.frombuffer(self.ele, np.float64).copy(), t=t,
                        heading=track_headings(lon, lat, piece), line=line, start=start,
                        origin=float(micros[0]) / 1e6)
