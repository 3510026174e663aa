"""Where things are on the Earth, for the GIS and Cesium outputs of ``tankcd report``: the terrain's
CRS checked, world x, y to WGS 84 longitude and latitude, an event's position, a track's pieces of
motion, and numbers as JSON text without a Python loop per row (docs/formats.md, "Outputs for
review")."""

from __future__ import annotations

import json
import math

import numpy as np

from tankcd_cli.errors import InputError

# a gap between two consecutive rows of a vehicle longer than this starts a new piece of motion, s
# (the poses do not record pieces; the same 30 s that makes a vehicle silent in an exercise)
PIECE_GAP_S = 30.0

# rows formatted to text at once (bounds the memory of one write whatever a track's length)
_CHUNK_ROWS = 1 << 20


def crs_source(review) -> str | None:
    """The input that carries the terrain's CRS (the terrain, else the scene), for messages."""
    for role in ("terrain", "scene"):
        for src in review.sources:
            if src.role == role:
                return src.path
    return None


def require_crs(review, what: str) -> None:
    """InputError (one line) when the review's terrain has no CRS: ``what`` (GeoJSON, CZML) needs one."""
    if not review.crs_wkt or not review.crs_wkt.strip():
        raise InputError(crs_source(review), f"the terrain has no CRS; {what} needs one (longitude and latitude)")


def lonlat_transformer(review):
    """A pyproj Transformer from the terrain's CRS to WGS 84 (EPSG:4326), x then y in, lon then lat out."""
    from pyproj import CRS, Transformer
    from pyproj.exceptions import CRSError

    try:
        crs = CRS.from_user_input(review.crs_wkt)
    except CRSError as exc:
        raise InputError(crs_source(review), f"the terrain's CRS is not one pyproj reads: {exc}") from None
    return Transformer.from_crs(crs, "EPSG:4326", always_xy=True)


def to_lonlat(transformer, x, y) -> tuple[np.ndarray, np.ndarray]:
    """World x, y (N,) m -> lon, lat (N,) deg (NaN in, NaN out)."""
    lon, lat = transformer.transform(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    lon, lat = np.asarray(lon, dtype=np.float64), np.asarray(lat, dtype=np.float64)
    bad = ~(np.isfinite(lon) & np.isfinite(lat))
    if bad.any():  # pyproj gives inf where it cannot: the same as no position
        lon, lat = lon.copy(), lat.copy()
        lon[bad] = np.nan
        lat[bad] = np.nan
    return lon, lat


def pieces(t: np.ndarray) -> list:
    """The pieces of motion of one track's rows: a list of (start, stop) row slices, split where two
    consecutive rows' times are more than ``PIECE_GAP_S`` apart (rows without a time never split)."""
    n = len(t)
    if n == 0:
        return []
    with np.errstate(invalid="ignore"):
        cut = np.flatnonzero(np.diff(np.asarray(t, dtype=np.float64)) > PIECE_GAP_S) + 1
    bounds = np.concatenate([[0], cut, [n]])
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


class _TrackRows:
    """One track's rows usable for placing events: those with x, y (and t) known, prepared once."""

    def __init__(self, tr):
        known = np.isfinite(tr.x) & np.isfinite(tr.y)
        timed = np.flatnonzero(known & np.isfinite(tr.t))
        self.t, self.x, self.y, self.z = tr.t[timed], tr.x[timed], tr.y[timed], tr.z[timed]
        located = np.flatnonzero(known)
        order = np.argsort(tr.step[located], kind="stable")  # the first row of a step first
        self.steps = tr.step[located][order]
        self.step_rows = located[order]
        self.track = tr

    def at_time(self, t: float):
        if len(self.t) == 0:
            return None
        # linear between the rows around t (z NaN when a neighbour is off the terrain)
        return (float(np.interp(t, self.t, self.x)), float(np.interp(t, self.t, self.y)),
                float(np.interp(t, self.t, self.z)))

    def at_step(self, step: int):
        k = int(np.searchsorted(self.steps, step))
        if k == len(self.steps) or self.steps[k] != step:
            return None
        r = self.step_rows[k]
        return float(self.track.x[r]), float(self.track.y[r]), float(self.track.z[r])


def event_places(review, transformer) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where each event of ``review.events`` is: lon, lat (N,) deg, z (N,) m (NaN where unknown)
    and own (N,) bool: whether the place is the event's own ``point``.

    An event's place is its ``point`` (x, y, z), else its vehicle's position at its time: the
    vehicle of its ``entity``, or the one track of a one-vehicle replay; linear between that
    vehicle's rows with a position (z NaN where a neighbour row has none), at its step's row
    when it has no time. NaN where neither is known (no such vehicle, no rows)."""
    n = len(review.events)
    x, y, z = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    own = np.zeros(n, bool)
    by_entity = {tr.entity: tr for tr in reversed(review.tracks)}  # the first of a name wins
    prepared: dict = {}
    for k, event in enumerate(review.events):
        point = event.get("point")
        if isinstance(point, (list, tuple)) and len(point) >= 2 and _finite(point[0]) and _finite(point[1]):
            x[k], y[k] = float(point[0]), float(point[1])
            z[k] = float(point[2]) if len(point) >= 3 and _finite(point[2]) else np.nan
            own[k] = True
            continue
        entity = event.get("entity")
        tr = by_entity.get(entity) if entity is not None else (review.tracks[0] if len(review.tracks) == 1 else None)
        if tr is None:
            continue
        rows = prepared.get(id(tr))
        if rows is None:
            rows = prepared[id(tr)] = _TrackRows(tr)
        t, step = event.get("t"), event.get("step")
        at = rows.at_time(float(t)) if _finite(t) else None
        if at is None and _finite(step):  # no time (or no timed rows): its step's row
            at = rows.at_step(int(step))
        if at is not None:
            x[k], y[k], z[k] = at
    lon, lat = to_lonlat(transformer, x, y) if n else (x, y)
    return lon, lat, z, own


def _finite(v) -> bool:
    try:
        return v is not None and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def numbers_text(columns: np.ndarray, decimals, row_sep: str = ",", col_sep: str = ",") -> str:
    """Rows of numbers as text: each row's values (fixed point, ``decimals`` a column) joined by
    ``col_sep``, rows joined by ``row_sep``; a non-finite value is ``null``. columns : (N, M).

    The compiled fixed-point formatter (``io.fixed_text``) writes CSV text; separators are then
    swapped with str.replace, so there is no Python loop per row (except for rows holding a
    non-finite value, rare: where they are, each row's empty cells become null)."""
    from tankcd_cli.io.fixed_text import table_text

    columns = np.ascontiguousarray(columns, dtype=np.float64)
    if columns.ndim == 1:
        columns = columns.reshape(-1, 1)
    n, m = columns.shape
    if n == 0:
        return ""
    decimals = np.broadcast_to(np.asarray(decimals, dtype=np.int64), (m,)).copy()
    text = table_text(columns, decimals, np.zeros((n, 0), np.int64), [], np.zeros(m, np.int64),
                      np.arange(m, dtype=np.int64))
    if text is None:  # too large for fixed point: Python's formatting (never for degrees and seconds)
        text = "".join(",".join("" if not math.isfinite(v) else f"{v:.{d}f}" for v, d in zip(row, decimals)) + "\n"
                       for row in columns.tolist())
    if not np.isfinite(columns).all():
        rows = text[:-1].split("\n")
        rows = [",".join(c if c else "null" for c in r.split(",")) for r in rows]
        text = "\n".join(rows) + "\n"
    if col_sep != ",":
        text = text.replace(",", col_sep)
    return text[:-1].replace("\n", row_sep)


def write_numbers(fh, columns: np.ndarray, decimals, row_sep: str = ",", col_sep: str = ",") -> None:
    """``numbers_text`` written to ``fh`` a chunk of rows at a time (a track of any length in
    bounded memory)."""
    n = len(columns)
    for start in range(0, n, _CHUNK_ROWS):
        if start:
            fh.write(row_sep)
        fh.write(numbers_text(columns[start:start + _CHUNK_ROWS], decimals, row_sep, col_sep))


def json_text(value) -> str:
    """JSON of a property value: numpy scalars and arrays as numbers and lists, a non-finite number
    as null (JSON has no NaN)."""
    try:
        return json.dumps(value, allow_nan=False, default=_plain, ensure_ascii=False)
    except ValueError:
        return json.dumps(_no_nan(value), allow_nan=False, default=_plain, ensure_ascii=False)


def _plain(value):
    if isinstance(value, np.ndarray):
        return _no_nan(value.tolist())
    if isinstance(value, np.generic):
        return _no_nan(value.item())
    raise TypeError(f"not JSON: {type(value).__name__}")


def _no_nan(value):
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, np.generic):
        return _no_nan(value.item())
    if isinstance(value, np.ndarray):
        return _no_nan(value.tolist())
    if isinstance(value, dict):
        return {k: _no_nan(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_no_nan(v) for v in value]
    return value
