"""Inside the vehicle: the gun barrel against the rear auxiliary fuel drums (the paper's section 4).

Kinematics in the vehicle frame: the turret turns by ``azimuth`` about the
hull's +z through the turret-ring centre (counter-clockwise, 0 = gun forward);
the gun turns by ``elevation`` about the trunnion axis (positive raises the
muzzle). The barrel is a cylinder of the gun's outer radius from the trunnion
to the muzzle; each drum a cylinder with its axis across the hull (along y).

Methods (``METHODS``): ``exact``, the cylinder-cylinder test of
``geometry.cylinders``; ``projection``, the paper's test on the shadows in the
vehicle's xoy and yoz planes (conservative: it may report a collision the
exact test rejects, never the reverse).
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.collision._internal import gun_path_contacts
from tankcd_cli.geometry.cylinders import TOL, cylinders_intersect, projections_overlap
from tankcd_cli.vehicle import Vehicle

METHODS = ("exact", "projection")
DRUMS = ("drum_left", "drum_right")


def barrel(vehicle: Vehicle, azimuth: np.ndarray, elevation: np.ndarray):
    """Barrel cylinders: centres (N, 3), unit axes (N, 3), half-length, radius (vehicle frame, m).

    azimuth, elevation : (N,) rad
    """
    az = np.asarray(azimuth, dtype=float).ravel()
    el = np.asarray(elevation, dtype=float).ravel()
    trunnion = np.column_stack([vehicle.turret_x + vehicle.trunnion_forward * np.cos(az),
                                vehicle.trunnion_forward * np.sin(az),
                                np.full(len(az), vehicle.trunnion_height)])
    axis = np.column_stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    half = vehicle.gun_length / 2
    return trunnion + half * axis, axis, half, vehicle.gun_radius


def drums(vehicle: Vehicle):
    """The two drums: (name, centre (3,), axis (3,), half-length, radius)."""
    if not vehicle.fuel_drums:
        return []
    out = []
    for name, side in zip(DRUMS, (1.0, -1.0)):
        out.append((name, np.array([vehicle.drum_x, side * vehicle.drum_y, vehicle.drum_z]), np.array([0.0, 1.0, 0.0]),
                    vehicle.drum_length / 2, vehicle.drum_radius))
    return out


def gun_hits_drums(vehicle: Vehicle, azimuth, elevation, method: str = "exact") -> np.ndarray:
    """(N, 2) bool: the barrel at each (azimuth, elevation) rad touches the left / right drum."""
    if method not in METHODS:
        raise ValueError(f"unknown internal method {method!r}; choose one of {', '.join(METHODS)}")
    c, a, h, r = barrel(vehicle, azimuth, elevation)
    out = np.zeros((len(c), 2), dtype=bool)
    test = cylinders_intersect if method == "exact" else projections_overlap
    for j, (_, dc, da, dh, dr) in enumerate(drums(vehicle)):
        out[:, j] = test(c, a, h, r, dc, da, dh, dr)
    return out


def elevation_envelope(vehicle: Vehicle, azimuth_deg: np.ndarray, resolution_deg: float = 0.01,
                       method: str = "exact") -> dict:
    """The lowest safe gun elevation at each turret azimuth, to ``resolution_deg`` by bisection.

    Returns arrays (deg): ``min_elevation`` (the depression limit the drums impose, or the gun's
    own limit where they impose none; NaN where even full elevation touches a drum),
    ``limited`` (bool: a drum, not the gun's own limit, decides), ``blocked_by`` (drum index or -1),
    ``checked`` (bool: every elevation above the limit, tested on a 0.25 deg grid, is clear).
    """
    azimuth_deg = np.asarray(azimuth_deg, dtype=float).ravel()
    az = np.radians(azimuth_deg)
    n = len(az)
    lo_deg, hi_deg = vehicle.gun_min_deg, vehicle.gun_max_deg

    at_min = gun_hits_drums(vehicle, az, np.radians(np.full(n, lo_deg)), method)
    at_max = gun_hits_drums(vehicle, az, np.radians(np.full(n, hi_deg)), method)
    limited = at_min.any(axis=1) & ~at_max.any(axis=1)
    blocked = at_max.any(axis=1)
    lo = np.full(n, lo_deg)  # colliding
    hi = np.full(n, hi_deg)  # clear
    idx = np.flatnonzero(limited)
    while len(idx) and (hi[idx] - lo[idx]).max() > resolution_deg:
        mid = 0.5 * (lo[idx] + hi[idx])
        h = gun_hits_drums(vehicle, az[idx], np.radians(mid), method).any(axis=1)
        lo[idx] = np.where(h, mid, lo[idx])
        hi[idx] = np.where(h, hi[idx], mid)
    result = np.where(limited, hi, lo_deg)
    result[blocked] = np.nan
    who = np.full(n, -1)
    if len(idx):
        just_below = gun_hits_drums(vehicle, az[idx], np.radians(lo[idx]), method)
        who[idx] = np.argmax(just_below, axis=1)
    who[blocked] = np.argmax(at_max[blocked], axis=1)
    # the limit is only meaningful if everything above it is clear: check on a grid
    checked = np.ones(n, dtype=bool)
    for e in np.arange(lo_deg, hi_deg + 1e-9, 0.25):
        above = np.isfinite(result) & (e >= result)
        if above.any():
            checked[above] &= ~gun_hits_drums(vehicle, az[above], np.radians(np.full(above.sum(), e)), method).any(axis=1)
    return {"azimuth": azimuth_deg, "min_elevation": result, "limited": limited, "blocked_by": who,
            "checked": checked}


GUN_PATH_STEP_DEG = 0.005
"""deg. Where the barrel is within ``GUN_CLOSE`` of a drum, the path is walked in steps this
long (in the larger of the two angles' changes) with the exact test: half the 0.01 deg to which the
envelope is given (docs/method.md#gun-against-the-rear-fuel-drums)."""

GUN_CLOSE = 2.5e-4
"""m. Below this clearance the walk along the path stops advancing by the distance (whose steps
would shrink without end on a grazing approach) and steps by ``GUN_PATH_STEP_DEG``."""


def first_gun_contacts(vehicle: Vehicle, azimuth0, dazimuth, elevation0, delevation,
                       step_deg: float = GUN_PATH_STEP_DEG) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the barrel first touches a drum along straight paths in (azimuth, elevation): from
    (azimuth0, elevation0) changing by (dazimuth, delevation) (M,) rad, each path parametrised by
    s in [0, 1]. Returns (found (M,) bool, s (M,) the first contact, NaN where none, drum (M,)
    index into ``DRUMS`` or -1).

    Conservative advancement on the exact cylinder distance: GJK gives the barrel's distance to
    each drum within ``TOL`` above the truth, and no point of the barrel moves faster than
    speed = |dazimuth| rho_az + |delevation| rho_el (m per unit of s; rho_az the farthest a barrel
    point is from the turret axis, rho_el from the trunnion), so a path whose clearance at s is
    d cannot touch a drum before s + (d - TOL) / speed. The walk (compiled: ``_internal``) advances
    by that, but never by less than ``step_deg`` of the larger angle change, and by just that step
    while the clearance is under ``GUN_CLOSE`` (where the distance's steps would shrink without
    end on a grazing approach), testing exactly at every stop, so a contact is never passed:
    its first point is found to ``step_deg`` (0.005 deg; a graze shorter than that along the path,
    the barrel dipping a fraction of a millimetre into a drum, may go unseen). Paths that start
    touching are reported at s = 0.
    """
    az0 = np.asarray(azimuth0, dtype=float).ravel()
    tanks = drums(vehicle)
    if not tanks or len(az0) == 0:
        return np.zeros(len(az0), dtype=bool), np.full(len(az0), np.nan), np.full(len(az0), -1, dtype=np.int64)
    for _, _, axis, _, _ in tanks:
        if not np.array_equal(axis, [0.0, 1.0, 0.0]):
            raise ValueError("the compiled gun path takes drums across the hull (axis +y)")
    rho_el = vehicle.gun_length + vehicle.gun_radius
    rho_az = abs(vehicle.trunnion_forward) + rho_el
    found, s_hit, who, errors = gun_path_contacts(
        az0, dazimuth, elevation0, delevation,
        [vehicle.turret_x, vehicle.trunnion_forward, vehicle.trunnion_height, vehicle.gun_length / 2,
         vehicle.gun_radius],
        np.array([t[1] for t in tanks]), np.array([[t[3], t[4]] for t in tanks]), rho_az, rho_el,
        np.radians(step_deg), GUN_CLOSE, TOL)
    if errors:
        raise np.linalg.LinAlgError("Array must not contain infs or NaNs.")
    found = found.astype(bool)
    return found, s_hit, who


def envelope_summary(vehicle: Vehicle, env: dict, step_deg: float) -> dict:
    """What the drums do to the gun's depression over an envelope taken every ``step_deg``, as
    plain values: ``fuel_drums``; ``limited_deg`` and ``blocked_deg``, the azimuth spans (deg)
    where a drum sets the limit and where even full elevation meets a drum; ``worst_deg``, the
    highest limit a drum sets (None where none does); ``gun_min_deg``, the gun's own limit."""
    limited = np.asarray(env["limited"], dtype=bool)
    blocked = ~np.isfinite(env["min_elevation"])
    return {"fuel_drums": bool(vehicle.fuel_drums), "gun_min_deg": float(vehicle.gun_min_deg),
            "limited_deg": float(limited.sum() * step_deg), "blocked_deg": float(blocked.sum() * step_deg),
            "worst_deg": float(np.nanmax(env["min_elevation"][limited])) if limited.any() else None}
