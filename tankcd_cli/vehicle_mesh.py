"""A vehicle's shape as triangles in the vehicle frame, generated from its dimensions.

Used when a scene names no vehicle mesh: hull box, two track runs, turret,
gun barrel (turret forward, gun level) and, when fitted, the two rear fuel
drums. Every triangle carries the index of its part (``PARTS``), so a
collision can say which part touched. ``detail`` sets the tessellation
(1: a few hundred triangles; 8: about 10 000).
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.vehicle import Vehicle

PARTS = ("hull", "track_left", "track_right", "turret", "gun", "drum_left", "drum_right")


def box(lo, hi, n: int = 1) -> np.ndarray:
    """Triangles (12 n^2, 3, 3) of an axis-aligned box, each face an n x n grid, outward winding."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    s = np.linspace(0.0, 1.0, n + 1)
    tris = []
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for side, value in ((0, lo[axis]), (1, hi[axis])):
            U, V = np.meshgrid(lo[u] + s * (hi[u] - lo[u]), lo[v] + s * (hi[v] - lo[v]), indexing="ij")
            P = np.zeros(U.shape + (3,))
            P[..., axis] = value
            P[..., u] = U
            P[..., v] = V
            a, b, c, d = P[:-1, :-1], P[1:, :-1], P[1:, 1:], P[:-1, 1:]
            quad = [np.stack([a, b, c], -2), np.stack([a, c, d], -2)]
            if side == (0 if (axis == 1) else 1):  # keep the normals pointing out
                quad = [q[..., ::-1, :] for q in quad]
            tris += [q.reshape(-1, 3, 3) for q in quad]
    return np.concatenate(tris)


def cylinder(centre, axis: int, radius: float, length: float, segments: int = 16, rings: int = 1) -> np.ndarray:
    """Triangles of a closed cylinder along a coordinate axis, centred at ``centre``."""
    u, v = [a for a in range(3) if a != axis]
    ang = np.linspace(0, 2 * np.pi, segments + 1)
    ring = np.stack([np.cos(ang), np.sin(ang)], -1) * radius
    along = np.linspace(-length / 2, length / 2, rings + 1)
    P = np.zeros((rings + 1, segments + 1, 3))
    P[..., axis] = along[:, None]
    P[..., u] = ring[None, :, 0]
    P[..., v] = ring[None, :, 1]
    P = P + np.asarray(centre, float)
    a, b, c, d = P[:-1, :-1], P[:-1, 1:], P[1:, 1:], P[1:, :-1]
    side = np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)])
    caps = []
    for k, sign in ((0, -1), (rings, 1)):
        cen = np.asarray(centre, float).copy()
        cen[axis] += sign * length / 2
        rim = P[k]
        tri = np.stack([np.broadcast_to(cen, rim[:-1].shape), rim[:-1], rim[1:]], -2)
        caps.append(tri if sign > 0 else tri[:, ::-1])
    return np.concatenate([side] + caps)


def vehicle_mesh(vehicle: Vehicle, detail: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Triangles (m, 3, 3) in the vehicle frame and their part index (m,) uint8."""
    v = vehicle
    n = max(1, int(detail))
    seg = 12 * n
    half_l, half_w = v.hull_length / 2, v.hull_width / 2
    g, w = v.track_gauge / 2, v.track_width / 2
    track_h = min(0.9, v.deck_height)
    track_half = v.track_length / 2 + 0.6  # sprocket and idler beyond the contact length
    parts = [
        box([-half_l, -half_w, v.ground_clearance], [half_l, half_w, v.deck_height], n),
        box([-track_half, g - w, 0.0], [track_half, g + w, track_h], n),
        box([-track_half, -g - w, 0.0], [track_half, -g + w, track_h], n),
        cylinder([v.turret_x, 0.0, 0.5 * (v.deck_height + v.hull_height)], 2, min(1.1, half_w * 0.65),
                 v.hull_height - v.deck_height, seg, n),
        cylinder([v.turret_x + v.trunnion_forward + v.gun_length / 2, 0.0, v.trunnion_height], 0, v.gun_radius,
                 v.gun_length, seg, 4 * n),
    ]
    if v.fuel_drums:
        for side in (1, -1):
            parts.append(cylinder([v.drum_x, side * v.drum_y, v.drum_z], 1, v.drum_radius, v.drum_length, seg, n))
    tris = np.concatenate(parts)
    label = np.concatenate([np.full(len(p), i, dtype=np.uint8) for i, p in enumerate(parts)])
    return tris, label
