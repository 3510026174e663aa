"""The geographic trajectory CSV (docs/formats.md, "Trajectory CSV", "Geographic positions"): a
CSV whose header has ``lon``, ``lat`` in place of ``x``, ``y`` (told by its header: the ``csv``
format of ``formats.INPUT_FORMATS``, read by ``csv_input``), its rows checked and converted to
the terrain's CRS here, and, without a heading column, its headings taken from the track.
Also what every geographic input shares: the terrain's CRS checked before any row is read.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.errors import InputError, warn
from tankcd_cli.io.geodesy import project, to_terrain_crs
from tankcd_cli.io.gpx import track_headings
from tankcd_cli.io.trajectory.chunk import ReadState
from tankcd_cli.io.trajectory.csv_rows import CsvRows, Layout, RawRows


def check_crs(crs: str | None, source: str) -> None:
    """Refuse (InputError naming ``source``) a terrain without a CRS, or with one pyproj cannot read or that is
    not projected, before any row is read."""
    project(np.zeros(0), np.zeros(0), crs or "", source=source)


def geographic_to_crs(lon, lat, heading_deg, compass: bool, crs: str, source: str):
    """lon, lat, heading (deg) -> x, y, yaw_deg in the terrain's CRS, and the first row that has no place
    there (-1 for none)."""
    h = np.radians(heading_deg)
    x, y, yaw = to_terrain_crs(lon, lat, crs, heading=h if compass else None, enu_yaw=None if compass else h,
                               source=source)
    yaw = np.degrees(yaw)
    bad = np.flatnonzero(~(np.isfinite(x) & np.isfinite(y) & np.isfinite(yaw)))
    return x, y, yaw, (int(bad[0]) if len(bad) else -1)


def out_of_range(lon: np.ndarray, lat: np.ndarray, lines: np.ndarray, name: str):
    """(the first row whose lon or lat is beyond -180 to 180, -90 to 90 degrees, its InputError), or
    (len(lon), None) for none."""
    bad = np.flatnonzero(~((np.abs(lon) <= 180.0) & (np.abs(lat) <= 90.0)))
    if not len(bad):
        return len(lon), None
    k = int(bad[0])
    c, value, limit = ("lon", lon[k], 180) if not abs(lon[k]) <= 180 else ("lat", lat[k], 90)
    return k, InputError(name, f"{float(value)!r} is out of range (-{limit} to {limit} degrees)",
                         where=f"line {lines[k]} column {c}")


def positions(lon: np.ndarray, lat: np.ndarray, heading: np.ndarray, lines: np.ndarray, lay: Layout,
              state: ReadState):
    """A chunk's k checked rows (lon, lat, heading as read, (k,) deg) as (x, y, yaw_deg, rows kept, error
    or None): converted to the terrain's CRS (``state.convert``), or lon, lat with the ENU yaw
    (``state.lonlat``), or as they are. A heading taken from the track is a compass bearing; NaN
    there (a vehicle that never moves) is yaw 0."""
    x, y, yaw = lon, lat, heading
    k = len(lon)
    error = None
    compass = lay.heading != "yaw_deg"  # heading_deg, or none: taken from the track as a compass bearing
    still = np.isnan(heading)
    if state.lonlat:
        yaw = np.where(still, 0.0, 90.0 - heading) if compass else heading
    if state.convert and k:
        x, y, yaw, bad = geographic_to_crs(lon, lat, np.where(still, 0.0, heading), compass, state.crs, lay.name)
        yaw[still] = 0.0
        if bad >= 0:
            k = bad
            error = InputError(lay.name, f"lon {float(lon[k])!r}, lat {float(lat[k])!r} has no place in the terrain's "
                                         "CRS (the projection cannot take it)", where=f"line {lines[k]}")
            x, y, yaw = x[:k], y[:k], yaw[:k]
    return x, y, yaw, k, error


def headed_from_track(rows: CsvRows, lay: Layout):
    """The raw rows of a lon, lat CSV without a heading column, each given the compass heading of its
    track as a GPX track's points are (``io.gpx.track_headings``: the azimuth to the same entity's
    next row; a row that does not move keeps the heading before it), in degrees in the heading
    column (NaN where the entity never moves). The heading needs the rows after a row, so the file
    is read whole first, as a GPX file is (memory follows the file; a warning says so)."""
    raws: list[RawRows] = []
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
