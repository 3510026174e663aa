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

from tankcd_cli.geometry.cylinders import cylinders_intersect, projections_overlap
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
