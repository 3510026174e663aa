"""Small Reviews built directly from arrays, for the report's writers' tests."""

from __future__ import annotations

import numpy as np

from tankcd_cli.report.review import Review, Source, Track

UTM33 = "EPSG:32633"


def wkt(crs: str) -> str:
    """The WKT of ``crs`` ('' stays '': no CRS), as a terrain store keeps it."""
    from pyproj import CRS

    return CRS.from_user_input(crs).to_wkt() if crs else ""


def quaternion(yaw, pitch=0.0, roll=0.0) -> np.ndarray:
    """(N, 4) qw, qx, qy, qz of R = Rz(yaw) Ry(pitch) Rx(roll) (rad), qw >= 0."""
    yaw, pitch, roll = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (yaw, pitch, roll)))
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    q = np.column_stack([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                         cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr])
    return q * np.where(q[:, :1] < 0, -1.0, 1.0)


def track(entity, t, x, y, z=None, yaw_deg=None, pitch=None, roll=None, status=None, step0=0) -> Track:
    t = np.asarray(t, dtype=np.float64)
    n = len(t)
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    z = np.full(n, 100.0) if z is None else np.asarray(z, dtype=np.float64)
    yaw_deg = np.zeros(n) if yaw_deg is None else np.asarray(yaw_deg, dtype=np.float64)
    pitch = np.zeros(n) if pitch is None else np.asarray(pitch, dtype=np.float64)
    roll = np.zeros(n) if roll is None else np.asarray(roll, dtype=np.float64)
    status = np.zeros(n, np.uint8) if status is None else np.asarray(status, np.uint8)
    q = quaternion(np.radians(yaw_deg), pitch, roll)
    off = status == 2
    z = z.copy()
    z[off] = np.nan
    q[off] = np.nan
    return Track(entity, np.arange(step0, step0 + n, dtype=np.int64), t, x, y, z, yaw_deg, q, status)


def two_vehicles(crs=UTM33, time_origin=None) -> Review:
    """Two vehicles near 15 E, 49.6 N (UTM 33N x ~ 500 km, y ~ 5.5e6), one with a 40 s gap (two
    pieces, the second of one row) and a row off the terrain; events of kinds vehicle (a point),
    obstacle (a point) and terrain (no point: at its vehicle's position)."""
    n = 20
    t_a = np.arange(n) * 0.5
    a = track("alpha", t_a, 500000.0 + 3.0 * t_a, 5.5e6 + 1.0 * t_a, z=300.0 + 0.1 * t_a,
              yaw_deg=np.full(n, 18.4), pitch=np.full(n, -0.05), roll=np.full(n, 0.02))
    t_b = np.concatenate([np.arange(10) * 1.0, [50.0]])
    status = np.zeros(11, np.uint8)
    status[4] = 2
    b = track("bravo", t_b, 500030.0 - 2.0 * t_b, 5.5e6 + 20.0 + 0.5 * t_b, z=np.full(11, 310.0),
              yaw_deg=np.full(11, 166.0), status=status, step0=100)
    events = [
        {"step": 3, "t": 1.75, "kind": "vehicle", "a": "alpha", "b": "bravo", "entity": "alpha",
         "a_part": "hull", "b_part": "hull", "point": [500005.25, 5500001.5, 301.0], "closing_speed": 2.5,
         "a_step": 3, "b_step": 101, "between": True},
        {"step": 5, "t": 2.5, "kind": "obstacle", "a": "hull", "b": "wall", "entity": "alpha",
         "point": [500007.5, 5500002.5, 300.5], "contacts": 1},
        {"step": 7, "t": 3.25, "kind": "terrain", "a": "hull", "b": "terrain", "entity": "alpha",
         "depth": 0.02, "between": True},
        {"step": 102, "t": None, "kind": "terrain", "a": "hull", "b": "terrain", "entity": "bravo", "depth": 0.05},
    ]
    settings = {"time_origin": time_origin} if time_origin else {}
    return Review(tracks=(a, b), events=events, crs_wkt=wkt(crs),
                  sources=(Source("poses", "poses.csv"), Source("terrain", "dem.tif")), settings=settings)
