"""The gate of the checks between vehicles: common spans of two vehicles' rigid segments proven clear
from bounds, so that the narrow phase (``collision.vehicles.first_vehicle_contacts``) runs only on
spans where a contact is possible (docs/formats.md, "Gates": ``vehicle_pairs``).

**The bound.** A segment is one vehicle's rigid motion over [t0, t1]: the hull origin c(t) on the
straight line from c0 to c1 at constant speed, the attitude turning at a constant rate from q0 to
q1 (by ``rotation_angle(q0, q1)`` in all), the turret and gun by dturret and dgun (rad). Take one
of the vehicle's rigid groups (hull, turret, gun) with its root box [lo, hi] in the vehicle frame
(turret and gun 0): every point of the group lies within h = |hi - lo| / 2 of the box centre m.
At the segment's start the group is placed rigidly (``group_placements``), so its points lie in
the sphere of radius h about m(t0), the box centre so placed. Any point x of the group moves as

    x(t) - x(t0) = (c(t) - c(t0)) + (R(t) p(t) - R(t0) p(t0)),

p(t) the point in the hull frame under the articulation at t. The second term is at most
``turn * radius + |dturret| * turret_radius + |dgun| * gun_radius`` (``BodyGroup.bound_rate``
without its travel: the turn about the hull origin moves a point at most the angle times its
distance, which ``radius`` bounds under any articulation, and each joint moves it at most its
change times its distance from the joint), call it e. So over the whole segment the group lies in
the sphere of radius h + e about o + c(t), with o = m(t0) - c(t0): a sphere whose centre moves with
the hull origin, on a straight line at constant velocity.

**The proof.** For two vehicles a and b over a common span [u0, u1] of their segments, the
centres' difference is D(t) = (o_a - o_b) + c_a(t) - c_b(t), linear in t: D(u0) + (t - u0) V with
V the difference of the two origins' velocities. Its least length over the span is that of the
closest point of a line segment to the origin (closed form, the minimiser clipped to the span).
If for every pair of groups (one of a, one of b) that least length exceeds r_a + r_b + ``MARGIN``
(r = h + e), the spheres are apart at every instant of the span, so are the bodies: the exact
check finds no contact there (neither one present at the span's start nor one along it; the
sweep's "a pass within 1 mm may count" lies inside the margin), and the span needs no narrow phase.
The relative velocity, not the sum of speeds, is what closes the gap: vehicles driving side by
side (a platoon abreast) are proven clear whatever their speed.

The bound is exact, never an estimate: every term is a maximum over the segment, from its own ends.
``MARGIN`` (1 cm) is ten times the sweep's 1 mm band and far above the rounding of the coordinates
(UTM northings of 4e6 m carry about 1e-9 m), so the two computations of a place (here, and the
narrow phase's cut of the segment) differing in the last bits never turn a verdict.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.collision.vehicle_body import VehicleBody, group_placements
from tankcd_cli.geometry.motion import quaternion_matrix, rotation_angle

MARGIN = 0.01
"""m. A span is proven clear only when every pair of group spheres stays more than this apart."""

SLOTS = 3  # hull, turret, gun (``vehicle_body.GROUPS``)


@dataclass(frozen=True)
class GroupSpheres:
    """Each segment's group spheres: offset (M, 3, 3) the centre of group slot g (0 hull, 1 turret,
    2 gun) at the segment's start minus the hull origin there (m), radius (M, 3) the sphere's radius
    grown by the group's turn and articulation bound over the segment (m; NaN for a group the body
    has not)."""

    offset: np.ndarray
    radius: np.ndarray


def group_spheres(body: VehicleBody, q0, c0, q1, turret0, dturret, gun0, dgun) -> GroupSpheres:
    """The group spheres of M segments of one kind of vehicle: hull attitude q0 -> q1 (M, 4), origin
    c0 (M, 3) at the start, turret0, gun0 (M,) rad at the start, changing by dturret, dgun (M,) rad
    (``replay.between_rows.Segments``'s fields). Each sphere holds its group throughout the segment
    once its centre is carried along with the hull origin (the module's docstring)."""
    q0 = np.asarray(q0, dtype=float)
    c0 = np.asarray(c0, dtype=float)
    m = len(q0)
    offset = np.zeros((m, SLOTS, 3))
    radius = np.full((m, SLOTS), np.nan)
    R0 = quaternion_matrix(q0)
    turn = rotation_angle(q0, q1)
    for g in body.groups:
        R, t = group_placements(body, g, R0, c0, np.asarray(turret0, float), np.asarray(gun0, float))
        lo, hi = g.tree.lo[0, :3], g.tree.hi[0, :3]
        centre = np.einsum("nij,j->ni", R, 0.5 * (lo + hi)) + t
        offset[:, g.kind] = centre - c0
        half = 0.5 * float(np.linalg.norm(hi - lo)) * (1 + 1e-9)
        radius[:, g.kind] = half + g.bound_rate(0.0, turn, dturret, dgun)
    return GroupSpheres(offset, radius)


def clear_spans(spheres_a: GroupSpheres, a_t0, a_t1, a_c0, a_c1, spheres_b: GroupSpheres, b_t0, b_t1, b_c0,
                b_c1, u0, u1) -> np.ndarray:
    """(P,) bool: the common span [u0, u1] (P,) s of segment a and segment b is proven free of any
    contact between the two vehicles. Per side: its spheres (P rows), its segment's time span t0, t1
    (P,) s and hull origin c0, c1 (P, 3) m at its ends. False wherever the proof does not hold."""
    u0 = np.asarray(u0, dtype=float)
    u1 = np.asarray(u1, dtype=float)

    def origin(t0, t1, c0, c1):
        length = np.asarray(t1, float) - np.asarray(t0, float)
        v = np.where(length[:, None] > 0, (c1 - c0) / np.where(length > 0, length, 1.0)[:, None], 0.0)
        return c0 + (u0 - t0)[:, None] * v, v

    pa, va = origin(a_t0, a_t1, a_c0, a_c1)
    pb, vb = origin(b_t0, b_t1, b_c0, b_c1)
    p0 = pa - pb  # the origins' difference at u0
    vel = va - vb
    vv = np.einsum("ij,ij->i", vel, vel)
    span = np.maximum(u1 - u0, 0.0)
    clear = np.ones(len(u0), dtype=bool)
    for ga in range(SLOTS):
        ra = spheres_a.radius[:, ga]
        for gb in range(SLOTS):
            rb = spheres_b.radius[:, gb]
            present = ~(np.isnan(ra) | np.isnan(rb))
            if not present.any():
                continue
            d0 = p0 + spheres_a.offset[:, ga] - spheres_b.offset[:, gb]
            # the least |d0 + tau vel| over tau in [0, span]: the convex quadratic's minimiser, clipped
            with np.errstate(invalid="ignore", divide="ignore"):
                tau = np.where(vv > 0, -np.einsum("ij,ij->i", d0, vel) / np.where(vv > 0, vv, 1.0), 0.0)
            tau = np.clip(tau, 0.0, span)
            least = np.linalg.norm(d0 + tau[:, None] * vel, axis=1)
            apart = least > np.where(present, ra + rb, 0.0) + MARGIN
            clear &= apart | ~present
    return clear
