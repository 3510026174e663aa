"""Any trajectory input written as the trajectory CSV tankcd reads (``export_trajectory``, for
``tankcd export``): in the terrain's CRS, or in lon, lat (EPSG:4326), its clock kept.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.errors import InputError, warn
from tankcd_cli.io.atomic import output_text
from tankcd_cli.io.fixed_text import table_text
from tankcd_cli.io.geodesy import NO_CRS
from tankcd_cli.io.trajectory.chunk import TrajectoryChunk, utc_text
from tankcd_cli.io.trajectory.reader import TrajectoryReader

EXPORT_COLUMNS = ("t", "entity", "x", "y", "yaw_deg", "turret_deg", "gun_deg")  # turret, gun: where the input has them
_EXPORT_DECIMALS = np.array([9, 6, 6, 9, 9, 9])  # t (ns), x, y (um), angles (1e-9 deg)
_EXPORT_LONLAT_DECIMALS = np.array([9, 10, 10, 9, 9, 9])  # lon, lat to 1e-10 deg (about 11 um)
EXPORT_NO_CRS = ("a geographic trajectory (lon, lat; GPX; a DIS capture) is exported in a CRS: give --terrain, "
                 "--scene or --crs (EPSG:32633, or EPSG:4326 for lon, lat)")


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
    """A chunk's rows as the export's CSV lines (``export_trajectory``'s decimals)."""
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
