"""The hull's bottom against the terrain: how far the ground rises above the bottom face, exactly.

The bottom face (hull length x width, at ground clearance, parallel to the support plane)
seen from above is a parallelogram; the highest ground above its plane comes from the same
exact footprint pass as the tracks' contact patches (``terrain.footprint``), so a contact
between sample points is never missed. ``hull_bottom_points`` samples the face: the dense
oracle the tests compare the exact depth with.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.vehicle import Vehicle


def hull_bottom_points(vehicle: Vehicle, along: int = 9, across: int = 5) -> np.ndarray:
    """Points (k, 3) of the hull's bottom face in the vehicle frame (at ground-clearance height)."""
    u = np.linspace(-vehicle.hull_length / 2, vehicle.hull_length / 2, along)
    v = np.linspace(-vehicle.hull_width / 2, vehicle.hull_width / 2, across)
    U, V = np.meshgrid(u, v)
    return np.column_stack([U.ravel(), V.ravel(), np.full(U.size, vehicle.ground_clearance)])


def hull_bottom_face(vehicle: Vehicle, planes: np.ndarray, roll: np.ndarray, pitch: np.ndarray):
    """The hull's bottom face seen from above and its plane: quads (N, 2, 4, 2) in the heading
    frame (a left and a right half, counter-clockwise) and planes (N, 3) (a + b u + c v).

    The face (hull length x width, at ground clearance, parallel to the support plane) seen from
    above is a parallelogram; its plane is the support plane moved up to the face's tilted centre.
    """
    L, W, h = vehicle.hull_length / 2, vehicle.hull_width / 2, vehicle.ground_clearance
    X = np.array([[-L, L, L, -L], [-L, L, L, -L]])
    Y = np.array([[0.0, 0.0, W, W], [-W, -W, 0.0, 0.0]])
    # the attitude in the heading frame, M = Ry(pitch) Rx(roll), applied to each corner (X, Y, h)
    cp, sp = np.cos(pitch)[:, None, None], np.sin(pitch)[:, None, None]
    cr, sr = np.cos(roll)[:, None, None], np.sin(roll)[:, None, None]
    quads = np.stack([cp * X + sp * sr * Y + sp * cr * h, cr * Y - sr * h], axis=-1)
    # the bottom plane: parallel to the support plane, through the moved centre of the face
    centre = (sp * cr * h)[:, 0, 0], (-sr * h)[:, 0, 0], (cp * cr * h)[:, 0, 0]
    a, b, c = planes[:, 0], planes[:, 1], planes[:, 2]
    bottom = np.column_stack([a + centre[2] - b * centre[0] - c * centre[1], b, c])
    return np.ascontiguousarray(quads), bottom


def hull_bottom_depth(surface, vehicle, x, y, yaw, planes, roll, pitch, dem: bool = True):
    """How far the ground rises above the hull's bottom face (N,), m (-inf where none of it is over terrain).

    Exact, like the track patches: the bottom face (see ``hull_bottom_face``) split into a left
    and a right half, and the highest ground above its plane found by the same footprint pass.
    """
    if len(x) == 0:
        return np.zeros(0)
    quads, bottom = hull_bottom_face(vehicle, planes, roll, pitch)
    high, _, status = surface.highest_over_patches(x, y, yaw, quads, bottom, exact_cells=dem)
    return np.where(status == 0, high, -np.inf)


def hull_bottom_contacts(surface, vehicle, x, y, yaw, planes, roll, pitch, tolerance: float):
    """The poses whose ground rises more than ``tolerance`` m above the hull's bottom face:
    (indices (K,), depths (K,) m), equal to ``hull_bottom_depth`` > tolerance.

    The surface's bound (its posts above the bottom plane) clears most poses first; only the
    rest take the exact pass. The bound is compared with a margin far above rounding, so it
    never clears a pose the exact pass would report.
    """
    if len(x) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    quads, bottom = hull_bottom_face(vehicle, planes, roll, pitch)
    bound = surface.highest_above_plane_bound(x, y, yaw, quads, bottom)
    maybe = np.flatnonzero(~(bound <= tolerance - 1e-6))  # NaN and +inf bounds go to the exact pass
    high, _, status = surface.highest_over_patches(x[maybe], y[maybe], yaw[maybe], quads[maybe], bottom[maybe])
    depth = np.where(status == 0, high, -np.inf)
    hit = depth > tolerance
    return maybe[hit], depth[hit]
