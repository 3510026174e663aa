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

from dataclasses import dataclass

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


DRUM_WINDOW_MARGIN = 1e-3
"""m. The drum window is the drums' shadows grown by this beyond the barrel's reach (10^6 times the
exact test's ``TOL``): rounding in the window's angles is far below it."""


@dataclass(frozen=True)
class DrumWindow:
    """The turret azimuths (rad, vehicle frame, 0 = gun forward) at which the barrel can touch a
    drum at some elevation: the arc ``centre`` +- ``half_width`` (``half_width`` >= pi: every
    azimuth; an empty window, no drums, has ``half_width`` -1)."""

    centre: float
    half_width: float


def drum_window(vehicle: Vehicle) -> DrumWindow:
    """The arc of turret azimuths outside which the barrel touches no drum, whatever its elevation.

    Proof. Seen from above (the projection onto the hull's xy plane, which moves no point farther
    from another), the barrel, a cylinder of radius r about the segment from the trunnion to the
    muzzle, lies within r of that segment's shadow. At azimuth az and elevation el (|el| < 90 deg,
    cos el > 0) the shadow is the points c + t (cos az, sin az), c the turret axis (turret_x, 0),
    for t from trunnion_forward to trunnion_forward + gun_length cos el: on the ray from c at az,
    or within |trunnion_forward| of c where that is negative. So the barrel's shadow lies within
    rho = r + max(0, -trunnion_forward) of the ray. A drum's shadow is the rectangle of its axis
    (along y) grown by its radius; a barrel touching it has a shadow meeting it, so the ray meets
    the rectangle grown by rho + ``DRUM_WINDOW_MARGIN`` in x and y (which holds every point within
    that distance). The rays from c that meet a convex set not holding c make the arc between the
    directions of its corners (narrower than pi); for both drums, the shortest arc holding all
    their corners' directions (the complement of the widest gap between them, when that gap is
    wider than pi) holds both arcs. Where c lies in a grown rectangle, or no gap is wider than pi,
    the window is every azimuth: nothing is proven."""
    tanks = drums(vehicle)
    if not tanks:
        return DrumWindow(0.0, -1.0)
    grow = vehicle.gun_radius + max(0.0, -vehicle.trunnion_forward) + DRUM_WINDOW_MARGIN
    c = np.array([vehicle.turret_x, 0.0])
    angles = []
    for _, centre, axis, half, radius in tanks:
        # the shadow's half-extents: the radius across the axis, the half-length (and the radius) along it
        ext = np.abs(axis[:2]) * half + radius + grow
        lo, hi = centre[:2] - ext - c, centre[:2] + ext - c
        if lo[0] <= 0 <= hi[0] and lo[1] <= 0 <= hi[1]:
            return DrumWindow(0.0, np.pi)
        corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        angles.append(np.arctan2(corners[:, 1], corners[:, 0]))
    a = np.sort(np.concatenate(angles))
    gaps = np.diff(np.concatenate([a, a[:1] + 2 * np.pi]))
    k = int(np.argmax(gaps))
    if gaps[k] <= np.pi:
        return DrumWindow(0.0, np.pi)
    first, last = a[(k + 1) % len(a)], a[k]  # the arc runs from after the widest gap round to its start
    width = (last - first) % (2 * np.pi)
    return DrumWindow(float(np.angle(np.exp(1j * (first + width / 2)))), float(width / 2 + 1e-9))


def drum_window_clear(window: DrumWindow, azimuth0, dazimuth, elevation0, delevation) -> np.ndarray:
    """(M,) bool: the straight paths in (azimuth, elevation), from (azimuth0, elevation0) changing
    by (dazimuth, delevation) (M,) rad, that never enter the ``window`` (``drum_window``), with the
    gun below 90 deg of elevation all along (the window's proof needs cos el > 0): no barrel
    position on them touches a drum, and ``first_gun_contacts`` would find none. A path's
    azimuths are the arc between its ends (|dazimuth| long), which misses centre +- h exactly when
    neither copy of the window, at 0 or at 2 pi from the path's start measured from the centre,
    meets it. Paths with a NaN are never clear."""
    az0 = np.asarray(azimuth0, dtype=float).ravel()
    daz = np.asarray(dazimuth, dtype=float).ravel()
    el0 = np.asarray(elevation0, dtype=float).ravel()
    el1 = el0 + np.asarray(delevation, dtype=float).ravel()
    h = window.half_width
    if h < 0:
        return np.isfinite(az0) & np.isfinite(daz)  # no drums: nothing to touch
    if h >= np.pi:
        return np.zeros(len(az0), dtype=bool)
    with np.errstate(invalid="ignore"):
        start = (np.minimum(az0, az0 + daz) - window.centre + np.pi) % (2 * np.pi) - np.pi  # in [-pi, pi)
        end = start + np.abs(daz)
        meets = ((start <= h) & (end >= -h)) | (end >= 2 * np.pi - h)
        level = (np.abs(el0) < np.pi / 2) & (np.abs(el1) < np.pi / 2)
        return np.isfinite(end) & level & ~meets


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
