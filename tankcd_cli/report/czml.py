"""A replay's tracks and events as a CZML document for Cesium: a clock over the exercise, each
vehicle's time-tagged positions and orientations, each event a point from its time
(docs/formats.md, "Outputs for review").

Orientation: a pose's quaternion turns the vehicle frame (REP 103: x forward, y left, z up) into
the world frame, whose x and y are grid east and grid north of the terrain's projected CRS. True
east and north at the vehicle are turned from the grid's about the vertical (by the meridian
convergence in a conformal projection such as UTM). The turn is measured at each row along the
vehicle's own heading: the points 1 m behind and ahead of it along its grid yaw are converted to
WGS 84 and the chord between them read in the local (true) ENU axes, so the vehicle's forward
axis points where its heading does on the ground in any projection, conformal or not. The local
ENU axes at its longitude and latitude are turned into ECEF by Rz(lon + 90 deg) Rx(90 deg - lat).
So CZML's ``unitQuaternion`` (vehicle -> Earth-fixed, written x, y, z, w) is
q_ecef = qz(lon + 90) qx(90 - lat) qz(true yaw - grid yaw) q_pose. The projection's scale (a grid
metre is not quite a ground metre) does not enter: the attitude's pitch and roll are kept.

Written packet by packet, a vehicle's numbers formatted a chunk of rows at a time.
"""

from __future__ import annotations

import datetime as _dt
import html

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.report import places

DEFAULT_EPOCH = "2000-01-01T00:00:00Z"  # t = 0 of a replay whose times are relative
VEHICLE_HEIGHT_M = 2.2  # the box drawn for a vehicle
T_DECIMALS = 6
DEG_DECIMALS = 8  # about 1 mm
H_DECIMALS = 3
Q_DECIMALS = 9

_VEHICLE_COLOURS = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (148, 103, 189), (140, 86, 75),
                    (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207), (214, 39, 40))
EVENT_COLOURS = {"vehicle": (220, 20, 60), "obstacle": (255, 140, 0), "terrain": (160, 82, 45),
                 "off_terrain": (148, 0, 211), "internal": (30, 144, 255)}
_OTHER_EVENT_COLOUR = (128, 128, 128)


def write_czml(review, path: str) -> None:
    """Write ``review`` (``report.review.Review``) to ``path`` as a CZML document (a JSON array of
    packets): ``document`` first, then a packet per vehicle (entity order), then one per event
    (the file's order). A terrain without a CRS, or with a geographic one, is an InputError, and
    nothing is written."""
    from tankcd_cli.io.atomic import output_text

    places.require_crs(review, "CZML")
    transformer = places.lonlat_transformer(review)
    if transformer.source_crs is not None and transformer.source_crs.is_geographic:
        raise InputError(places.crs_source(review), "the terrain's CRS is geographic; CZML's orientations need a "
                                                    "projected CRS (metres)")
    clock = _Clock(review)
    with output_text(path) as fh:
        fh.write("[\n")
        fh.write(places.json_text(_document_packet(review, clock)))
        for k, tr in enumerate(review.tracks):
            fh.write(",\n")
            _write_vehicle(fh, review, transformer, clock, tr, _VEHICLE_COLOURS[k % len(_VEHICLE_COLOURS)])
        lon, lat, z, _ = places.event_places(review, transformer)
        for n, event in enumerate(review.events):
            fh.write(",\n")
            fh.write(places.json_text(_event_packet(clock, n, event, lon[n], lat[n], z[n])))
        fh.write("\n]\n")


class _Clock:
    """The document's times: the epoch (t = 0) and the exercise's first and last time as ISO 8601."""

    def __init__(self, review):
        origin = review.settings.get("time_origin") if isinstance(review.settings, dict) else None
        self.known = False
        self.epoch_text = DEFAULT_EPOCH
        if isinstance(origin, str) and origin:
            try:
                self.epoch = _parse_instant(origin)
                self.epoch_text = origin
                self.known = True
            except ValueError:
                pass
        if not self.known:
            self.epoch = _parse_instant(DEFAULT_EPOCH)
        lo, hi = review.time_span
        self.t0, self.t1 = (float(lo), float(hi)) if np.isfinite(lo) else (0.0, 0.0)
        self.start, self.stop = self.iso(self.t0), self.iso(self.t1)

    def iso(self, t: float) -> str:
        """The instant ``t`` s after the epoch, ISO 8601 UTC (microseconds where there are any)."""
        at = self.epoch + _dt.timedelta(seconds=float(t))
        text = at.strftime("%Y-%m-%dT%H:%M:%S")
        if at.microsecond:
            text += f".{at.microsecond:06d}".rstrip("0")
        return text + "Z"

    def interval(self, a: float, b: float) -> str:
        return f"{self.iso(a)}/{self.iso(b)}"


def _parse_instant(text: str) -> _dt.datetime:
    at = _dt.datetime.fromisoformat(text[:-1] + "+00:00" if text.endswith("Z") else text)
    if at.tzinfo is None:
        at = at.replace(tzinfo=_dt.timezone.utc)
    return at.astimezone(_dt.timezone.utc)


def _document_packet(review, clock: _Clock) -> dict:
    poses = next((s.path for s in review.sources if s.role == "poses"), None)
    times = (f"t = 0 is the replay's time origin, {clock.epoch_text}." if clock.known else
             f"The replay's times are relative: t = 0 is written as {DEFAULT_EPOCH} (a fixed epoch, not a real date).")
    description = (f"tankcd review{': ' + poses if poses else ''}. {times} Heights are the poses' world z "
                   "(above the terrain's vertical datum), written as heights above the WGS 84 ellipsoid as they "
                   "are. Rows off the terrain (no height, no attitude) and rows without a time are left out of "
                   "the vehicles' positions and orientations.")
    return {"id": "document", "name": f"tankcd review{': ' + poses if poses else ''}", "version": "1.0",
            "description": description,
            "clock": {"interval": f"{clock.start}/{clock.stop}", "currentTime": clock.start, "multiplier": 1,
                      "range": "LOOP_STOP", "step": "SYSTEM_CLOCK_MULTIPLIER"}}


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton products p q of (N, 4) w, x, y, z quaternions."""
    pw, px, py, pz = p.T
    qw, qx, qy, qz = q.T
    return np.column_stack([pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
                            pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw])


def _axis_quaternion(angle: np.ndarray, axis: int) -> np.ndarray:
    """(N, 4) w, x, y, z of turns by ``angle`` (N,) rad about the x (0) or z (2) axis."""
    q = np.zeros((len(angle), 4))
    q[:, 0] = np.cos(angle / 2)
    q[:, 1 + axis] = np.sin(angle / 2)
    return q


def true_minus_grid_yaw(transformer, x: np.ndarray, y: np.ndarray, yaw_deg: np.ndarray, lon: np.ndarray,
                        lat: np.ndarray) -> np.ndarray:
    """The turn (rad) from grid to true ENU axes along each heading: true ENU yaw - grid yaw.

    x, y : (N,) m in the projected CRS; yaw_deg : (N,) grid yaw, degrees from grid east
    lon, lat : (N,) deg of (x, y). The chord between the points 1 m behind and ahead along the
    heading, through WGS 84 ECEF, read in the local ENU axes (-convergence for a conformal CRS)."""
    from tankcd_cli.io.geodesy import geodetic_to_ecef

    a = np.radians(yaw_deg)
    dx, dy = np.cos(a), np.sin(a)
    ahead = geodetic_to_ecef(*places.to_lonlat(transformer, x + dx, y + dy))
    behind = geodetic_to_ecef(*places.to_lonlat(transformer, x - dx, y - dy))
    d = ahead - behind
    lo, la = np.radians(lon), np.radians(lat)
    east = -np.sin(lo) * d[:, 0] + np.cos(lo) * d[:, 1]
    north = -np.sin(la) * (np.cos(lo) * d[:, 0] + np.sin(lo) * d[:, 1]) + np.cos(la) * d[:, 2]
    true_yaw = np.arctan2(north, east)
    return np.angle(np.exp(1j * (true_yaw - a)))


def ecef_quaternions(quaternion: np.ndarray, lon: np.ndarray, lat: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """Pose attitudes -> vehicle -> ECEF rotations.

    quaternion : (N, 4) qw, qx, qy, qz, vehicle -> world (grid ENU of the projected CRS)
    lon, lat : (N,) deg; turn : (N,) rad, true ENU yaw - grid yaw (``true_minus_grid_yaw``)
    Returns (N, 4) w, x, y, z, unit, each in the hemisphere of the one before (so that Cesium's
    interpolation between rows takes the short way)."""
    q = np.asarray(quaternion, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    enu_to_ecef = _qmul(_axis_quaternion(np.radians(lon) + np.pi / 2, 2),
                        _axis_quaternion(np.pi / 2 - np.radians(lat), 0))
    out = _qmul(enu_to_ecef, _qmul(_axis_quaternion(np.asarray(turn, dtype=np.float64), 2), q))
    if len(out) > 1:
        same = np.einsum("ij,ij->i", out[1:], out[:-1]) >= 0
        out *= np.concatenate([[1.0], np.cumprod(np.where(same, 1.0, -1.0))])[:, None]
    return out


def _write_vehicle(fh, review, transformer, clock: _Clock, tr, colour) -> None:
    name = tr.entity or "vehicle"
    head = {"id": f"vehicle/{tr.entity}", "name": name}
    timed = np.flatnonzero(np.isfinite(tr.t))
    t_all = tr.t[timed]
    spans = places.pieces(t_all)
    if spans:
        head["availability"] = [clock.interval(t_all[a], t_all[b - 1]) for a, b in spans]
    lon, lat = places.to_lonlat(transformer, tr.x[timed], tr.y[timed])
    ok = np.isfinite(lon) & np.isfinite(tr.z[timed]) & np.isfinite(tr.quaternion[timed]).all(axis=1)
    rows = timed[ok]
    fh.write(places.json_text(head)[:-1])
    if len(rows):
        lon, lat = lon[ok], lat[ok]
        t = tr.t[rows]
        fh.write(f',"position":{{"epoch":"{clock.epoch_text}","cartographicDegrees":[')
        places.write_numbers(fh, np.column_stack([t, lon, lat, tr.z[rows]]),
                             [T_DECIMALS, DEG_DECIMALS, DEG_DECIMALS, H_DECIMALS])
        turn = true_minus_grid_yaw(transformer, tr.x[rows], tr.y[rows], tr.yaw_deg[rows], lon, lat)
        q = ecef_quaternions(tr.quaternion[rows], lon, lat, turn)
        fh.write(f']}},"orientation":{{"epoch":"{clock.epoch_text}","unitQuaternion":[')
        # CZML's order: x, y, z, w
        places.write_numbers(fh, np.column_stack([t, q[:, 1], q[:, 2], q[:, 3], q[:, 0]]),
                             [T_DECIMALS] + [Q_DECIMALS] * 4)
        fh.write("]}")
    rgba = list(colour) + [255]
    graphics = {
        "path": {"material": {"solidColor": {"color": {"rgba": rgba}}}, "width": 2, "leadTime": 0,
                 "trailTime": max(clock.t1 - clock.t0, 1.0), "resolution": 1},
        "box": {"dimensions": {"cartesian": [review.vehicle_length, review.vehicle_width, VEHICLE_HEIGHT_M]},
                "material": {"solidColor": {"color": {"rgba": list(colour) + [200]}}}, "outline": True,
                "outlineColor": {"rgba": [0, 0, 0, 255]}},
    }
    fh.write("," + places.json_text(graphics)[1:])


def _event_packet(clock: _Clock, n: int, event: dict, lon: float, lat: float, z: float) -> dict:
    kind = str(event.get("kind", ""))
    packet = {"id": f"event/{n}", "name": f"{kind} {event.get('a', '')} / {event.get('b', '')}".strip()}
    t = event.get("t")
    if isinstance(t, (int, float)) and np.isfinite(t):
        packet["availability"] = f"{clock.iso(t)}/{clock.iso(max(float(t), clock.t1))}"
    else:
        packet["availability"] = f"{clock.start}/{clock.stop}"
    point = {"color": {"rgba": list(EVENT_COLOURS.get(kind, _OTHER_EVENT_COLOUR)) + [255]}, "pixelSize": 10,
             "outlineColor": {"rgba": [255, 255, 255, 255]}, "outlineWidth": 1}
    if np.isfinite(lon):
        if not np.isfinite(z):  # no height known: drawn on the ground
            point["heightReference"] = "CLAMP_TO_GROUND"
        packet["position"] = {"cartographicDegrees": [round(float(lon), DEG_DECIMALS), round(float(lat), DEG_DECIMALS),
                                                      round(float(z), H_DECIMALS) if np.isfinite(z) else 0.0]}
    packet["point"] = point
    rows = "".join(f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(places.json_text(v))}</td></tr>"
                   for k, v in event.items())
    packet["description"] = f"<table>{rows}</table>"
    return packet
