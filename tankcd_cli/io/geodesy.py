"""Frames for recorded and geographic trajectories: WGS 84 ECEF, geodetic, local ENU, the terrain's grid.

Longitude and latitude are degrees (as every GIS and pyproj give them); rotations are radians.
Heights are metres above the WGS 84 ellipsoid.

Conventions (docs/formats.md, "Conventions: frames, units, signs"):

- local ENU at (lon, lat): x east, y north, z up along the ellipsoid normal;
- a compass ``heading`` (true heading) turns clockwise from true north; an ENU ``yaw``
  counter-clockwise from local east: ``yaw = pi/2 - heading``;
- a ``grid_yaw`` turns counter-clockwise from the projected CRS's +x (grid east). Grid east and
  true east differ by the meridian (grid) convergence: ``grid_yaw = enu_yaw + convergence`` with
  the convergence positive where true north lies counter-clockwise of grid north (east of the
  central meridian of a transverse Mercator zone in the northern hemisphere, west of it in the
  southern). It is pyproj's ``Factors.meridian_convergence`` (degrees) with this sign, which the
  tests prove against steps through pyproj's transforms and ``Geod.inv``. Here it is not taken
  from a formula: the grid direction is measured, a central difference through the CRS along
  the heading (+-0.5 m, see ``grid_yaw``): exact for any projection, conformal or not;
- DIS orientation (IEEE 1278.1 1.3.2 / 6.2.33): Euler angles psi, theta, phi turning the ECEF axes
  into the body's (x forward, y right, z down) by z, then the new y, then the new x:
  R_body->ECEF = Rz(psi) Ry(theta) Rx(phi);
- the vehicle's attitude is ROS REP 103 (x forward, y left, z up; R = Rz(yaw) Ry(pitch) Rx(roll),
  nose-up pitch negative, right side down roll positive): the DIS body frame with y and z flipped.
"""

from __future__ import annotations

import functools

import numpy as np

from tankcd_cli.errors import InputError

A = 6378137.0  # WGS 84 semi-major axis, m
F = 1 / 298.257223563
B = A * (1 - F)
E2 = F * (2 - F)  # first eccentricity squared
EP2 = E2 / (1 - E2)  # second
NO_CRS = "geographic input needs a terrain with a CRS (this terrain has none: classify a georeferenced DEM, or " \
         "give x, y in the terrain's frame)"


# -- positions -------------------------------------------------------------------------------------------
def ecef_to_geodetic(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """WGS 84 ECEF (N, 3) m -> lon (N,) deg, lat (N,) deg, h (N,) m above the ellipsoid.

    Heikkinen's closed form (exact in exact arithmetic; well below a millimetre in float64 for
    points within a few hundred kilometres of the surface)."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    x, y, z = xyz.T
    p2 = x * x + y * y
    p = np.sqrt(p2)
    z2 = z * z
    f54 = 54 * B * B * z2
    g = p2 + (1 - E2) * z2 - E2 * (A * A - B * B)
    c = E2 * E2 * f54 * p2 / (g * g * g)
    s = np.cbrt(1 + c + np.sqrt(c * c + 2 * c))
    k = s + 1 + 1 / s
    pp = f54 / (3 * k * k * g * g)
    q = np.sqrt(1 + 2 * E2 * E2 * pp)
    r0 = -(pp * E2 * p) / (1 + q) + np.sqrt(np.maximum(
        0.5 * A * A * (1 + 1 / q) - pp * (1 - E2) * z2 / (q * (1 + q)) - 0.5 * pp * p2, 0.0))
    t = p - E2 * r0
    u = np.sqrt(t * t + z2)
    v = np.sqrt(t * t + (1 - E2) * z2)
    z0 = B * B * z / (A * v)
    h = u * (1 - B * B / (A * v))
    lat = np.degrees(np.arctan2(z + EP2 * z0, p))
    lon = np.degrees(np.arctan2(y, x))
    return lon, lat, h


def geodetic_to_ecef(lon_deg, lat_deg, h=0.0) -> np.ndarray:
    """lon, lat (N,) deg and h (N,) m above the WGS 84 ellipsoid -> ECEF (N, 3) m."""
    lon, lat = np.radians(lon_deg), np.radians(lat_deg)
    h = np.asarray(h, dtype=np.float64)
    sl = np.sin(lat)
    n = A / np.sqrt(1 - E2 * sl * sl)
    return np.column_stack(np.broadcast_arrays((n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                                               (n * (1 - E2) + h) * sl)).astype(np.float64)


def enu_basis(lon_deg, lat_deg) -> np.ndarray:
    """(N, 3, 3): rows east, north, up of the local ENU frame at each (lon, lat), in ECEF; it turns
    ECEF vectors into ENU (``R @ v``); its transpose turns ENU into ECEF."""
    lon, lat = np.radians(np.atleast_1d(lon_deg)), np.radians(np.atleast_1d(lat_deg))
    so, co, sa, ca = np.sin(lon), np.cos(lon), np.sin(lat), np.cos(lat)
    zero = np.zeros_like(so)
    return np.stack([np.stack([-so, co, zero], -1), np.stack([-sa * co, -sa * so, ca], -1),
                     np.stack([ca * co, ca * so, sa], -1)], axis=1)


def ecef_to_enu_vectors(v: np.ndarray, lon_deg, lat_deg) -> np.ndarray:
    """Vectors (N, 3) in ECEF axes (a velocity, say) -> the same in local ENU axes at each (lon, lat)."""
    return np.einsum("nij,nj->ni", enu_basis(lon_deg, lat_deg), np.asarray(v, dtype=np.float64).reshape(-1, 3))


def enu_to_ecef_vectors(v: np.ndarray, lon_deg, lat_deg) -> np.ndarray:
    """Vectors (N, 3) in local ENU axes at each (lon, lat) -> the same in ECEF axes."""
    return np.einsum("nji,nj->ni", enu_basis(lon_deg, lat_deg), np.asarray(v, dtype=np.float64).reshape(-1, 3))


# -- orientations --------------------------------------------------------------------------------------
def _rz(a):
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], axis=1)


def _ry(a):
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], axis=1)


def _rx(a):
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], axis=1)


def dis_body_to_ecef(psi, theta, phi) -> np.ndarray:
    """(N, 3, 3) R_body->ECEF = Rz(psi) Ry(theta) Rx(phi) of DIS Euler angles (rad)."""
    psi, theta, phi = (np.atleast_1d(np.asarray(a, dtype=np.float64)) for a in (psi, theta, phi))
    return _rz(psi) @ _ry(theta) @ _rx(phi)


def dis_orientation_to_enu(psi, theta, phi, lon_deg, lat_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """DIS orientation (N,) rad at (lon, lat) (N,) deg -> the local ENU attitude (yaw, pitch, roll) (N,)
    rad in REP 103: yaw counter-clockwise from local (true) east.

    R = E B with B = Rz(psi) Ry(theta) Rx(phi) (body -> ECEF) and E the ENU rows (ECEF -> ENU);
    REP 103's frame is B's with y and z flipped. Only the entries the angles need are formed:
    the body's x axis in ENU (yaw, pitch) and the up components of its y and z axes (roll)."""
    psi, theta, phi = (np.asarray(a, dtype=np.float64) for a in (psi, theta, phi))
    lon, lat = np.radians(lon_deg), np.radians(lat_deg)
    cs, ss, ct, st, cf, sf = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta), np.cos(phi), np.sin(phi)
    co, so, ca, sa = np.cos(lon), np.sin(lon), np.cos(lat), np.sin(lat)
    # the body's axes in ECEF: the columns of B
    bx = (cs * ct, ss * ct, -st)
    by = (cs * st * sf - ss * cf, ss * st * sf + cs * cf, ct * sf)
    bz = (cs * st * cf + ss * sf, ss * st * cf - cs * sf, ct * cf)
    east = (-so, co, 0.0)
    north = (-sa * co, -sa * so, ca)
    up = (ca * co, ca * so, sa)

    def dot(a, b):
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]

    fwd_e, fwd_n, fwd_u = dot(east, bx), dot(north, bx), dot(up, bx)
    yaw = np.arctan2(fwd_n, fwd_e)
    pitch = -np.arcsin(np.clip(fwd_u, -1.0, 1.0))
    roll = np.arctan2(-dot(up, by), -dot(up, bz))  # REP 103's y (left) = -body y, z (up) = -body z
    return yaw, pitch, roll


def heading_to_enu_yaw(heading):
    """Compass heading (clockwise from true north, rad) -> ENU yaw (counter-clockwise from true east, rad)."""
    return np.pi / 2 - np.asarray(heading, dtype=np.float64)


def enu_yaw_to_heading(yaw):
    """ENU yaw -> compass heading in [0, 2 pi)."""
    return np.mod(np.pi / 2 - np.asarray(yaw, dtype=np.float64), 2 * np.pi)


def wrap_angle(a):
    """Angles to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=np.float64), 2 * np.pi)


# -- the terrain's CRS ---------------------------------------------------------------------------------
@functools.lru_cache(maxsize=8)
def lonlat_to_crs(crs_wkt: str, source: str | None):
    """A pyproj Transformer from WGS 84 longitude, latitude to the terrain's projected CRS (x, y in
    metres), cached; an InputError naming ``source`` for no CRS, one pyproj cannot read, or a
    geographic one."""
    if not crs_wkt or not crs_wkt.strip():
        raise InputError(source, NO_CRS)
    from pyproj import CRS, Transformer
    from pyproj.exceptions import CRSError

    try:
        crs = CRS.from_user_input(crs_wkt)
    except CRSError as exc:
        raise InputError(source, f"geographic input needs a terrain CRS that pyproj reads: {exc}") from None
    if crs.is_geographic:
        raise InputError(source, f"geographic input needs a terrain in a projected CRS (metres); this terrain's CRS "
                                 f"({crs.name}) is geographic")
    return Transformer.from_crs("EPSG:4326", crs, always_xy=True)


def project(lon_deg, lat_deg, crs_wkt: str, source: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """lon, lat (N,) deg (WGS 84) -> x, y (N,) in the projected CRS ``crs_wkt`` (any form pyproj takes)."""
    x, y = lonlat_to_crs(crs_wkt, source).transform(np.asarray(lon_deg, dtype=np.float64),
                                                    np.asarray(lat_deg, dtype=np.float64))
    return np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)


def grid_yaw(lon_deg, lat_deg, crs_wkt: str, *, heading=None, enu_yaw=None, source: str | None = None,
             step: float = 0.5) -> np.ndarray:
    """The direction in the projected CRS (counter-clockwise from grid east, rad) of a true ``heading``
    (clockwise from true north, rad) or a local ``enu_yaw`` (counter-clockwise from true east, rad) at
    each (lon, lat) (N,) deg.

    Measured through the CRS: the points ``step`` m behind and ahead of each point along a curve
    leaving it at that azimuth (dlat = s cos(az) / M, dlon = s sin(az) / (N cos(lat)), M and N the
    ellipsoid's radii of curvature) are projected, and the chord between them is the direction.
    The curve's tangent is the geodesic's, so this central difference gives the projected
    tangent with an error of order step^2 (far below 1e-9 rad), for any projection."""
    if (heading is None) == (enu_yaw is None):
        raise TypeError("give heading or enu_yaw")
    lon = np.asarray(lon_deg, dtype=np.float64)
    lat = np.asarray(lat_deg, dtype=np.float64)
    az = np.asarray(heading, dtype=np.float64) if heading is not None else enu_yaw_to_heading(enu_yaw)
    lon, lat, az = np.broadcast_arrays(lon, lat, az)
    phi = np.radians(lat)
    w2 = 1 - E2 * np.sin(phi) ** 2
    n = A / np.sqrt(w2)  # prime vertical radius of curvature
    m = A * (1 - E2) / (w2 * np.sqrt(w2))  # meridional
    dlat = np.degrees(step * np.cos(az) / m)
    with np.errstate(divide="ignore", invalid="ignore"):  # a pole has no heading: NaN there
        dlon = np.degrees(step * np.sin(az) / (n * np.cos(phi)))
    x1, y1 = project(lon + dlon, lat + dlat, crs_wkt, source)
    x0, y0 = project(lon - dlon, lat - dlat, crs_wkt, source)
    return np.arctan2(y1 - y0, x1 - x0)


def to_terrain_crs(lon_deg, lat_deg, crs_wkt: str, *, heading=None, enu_yaw=None,
                   source: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geographic positions and headings -> the terrain's frame.

    lon, lat : (N,) deg, WGS 84
    crs_wkt : the terrain's CRS (WKT or anything pyproj takes); empty: InputError naming ``source``
    heading : (N,) rad, compass (clockwise from true north); or enu_yaw (N,) rad (from true east)
    Returns x, y (N,) m in the CRS and grid_yaw (N,) rad in (-pi, pi], counter-clockwise from grid
    east: the trajectory CSV's ``yaw_deg`` (in degrees), the convergence applied.
    """
    x, y = project(lon_deg, lat_deg, crs_wkt, source)
    return x, y, grid_yaw(lon_deg, lat_deg, crs_wkt, heading=heading, enu_yaw=enu_yaw, source=source)


def meridian_convergence(lon_deg, lat_deg, crs_wkt: str, source: str | None = None) -> np.ndarray:
    """The convergence (rad) at each point: ``grid_yaw - enu_yaw`` (positive where true north lies
    counter-clockwise of grid north), measured as in :func:`grid_yaw` for a true heading of north."""
    north = grid_yaw(lon_deg, lat_deg, crs_wkt, heading=np.zeros(np.shape(lon_deg)), source=source)
    return wrap_angle(north - np.pi / 2)


def dis_to_terrain(location_ecef: np.ndarray, orientation: np.ndarray, crs_wkt: str, source: str | None = None):
    """DIS Entity State positions and orientations -> the terrain's frame.

    location_ecef : (N, 3) m; orientation : (N, 3) psi, theta, phi rad
    Returns a dict of (N,) arrays: ``x``, ``y`` (m, the CRS), ``h`` (m above the ellipsoid), ``lon``,
    ``lat`` (deg), ``grid_yaw`` (rad from grid east), ``pitch``, ``roll`` (rad, REP 103, about the
    local level: the same in the grid frame, which turns about the vertical only).
    """
    lon, lat, h = ecef_to_geodetic(location_ecef)
    orientation = np.asarray(orientation, dtype=np.float64).reshape(-1, 3)
    yaw, pitch, roll = dis_orientation_to_enu(orientation[:, 0], orientation[:, 1], orientation[:, 2], lon, lat)
    x, y, gyaw = to_terrain_crs(lon, lat, crs_wkt, enu_yaw=yaw, source=source)
    return {"x": x, "y": y, "h": h, "lon": lon, "lat": lat, "grid_yaw": gyaw, "pitch": pitch, "roll": roll}
