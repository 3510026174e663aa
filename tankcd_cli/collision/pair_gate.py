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

Why groups and the relative velocity: one sphere of ``VehicleBody.radius`` about each hull origin
(8.16 m for the T-72: any articulation) and the sum of the two vehicles' speed bounds (the centre's
speed plus the turn rate times that radius) prove nothing on platoons 12 m abreast (the spheres
overlap; at 5 m/s each, 20 m of closing per 2 s window against any gap): on the exercise benchmark
(200 vehicles, 1 min at 10 Hz) that bound clears none of 4,723 pair-windows over the window and
41 span by span, where this one clears 98.6 %.

The bound is exact, never an estimate: every term is a maximum over the segment, from its own ends.
``MARGIN`` (1 cm) is ten times the sweep's 1 mm band and far above the rounding of the coordinates
(UTM northings of 4e6 m carry about 1e-9 m), so the two computations of a place (here, and the
narrow phase's cut of the segment) differing in the last bits never turn a verdict.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.collision.vehicle_body import VehicleBody
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

    def take(self, idx) -> "GroupSpheres":
        return GroupSpheres(self.offset[idx], self.radius[idx])


def group_spheres(body: VehicleBody, q0, c0, q1, turret0, dturret, gun0, dgun) -> GroupSpheres:
    """The group spheres of M segments of one kind of vehicle: hull attitude q0 -> q1 (M, 4), origin
    c0 (M, 3) at the start, turret0, gun0 (M,) rad at the start, changing by dturret, dgun (M,) rad
    (``replay.between_rows.Segments``'s fields). Each sphere holds its group throughout the segment
    once its centre is carried along with the hull origin (the module's docstring)."""
    q0 = np.asarray(q0, dtype=float)
    m = len(q0)
    offset = np.zeros((m, SLOTS, 3))
    radius = np.full((m, SLOTS), np.nan)
    R0 = quaternion_matrix(q0)
    turn = rotation_angle(q0, q1)
    angles = (np.asarray(turret0, float), np.asarray(gun0, float))
    for g in body.groups:
        lo, hi = g.tree.lo[0, :3], g.tree.hi[0, :3]
        # the box centre articulated (the gun turns first, then the turret: ``group_placements``), then
        # turned with the hull: its offset from the hull origin
        point = np.broadcast_to(0.5 * (lo + hi), (m, 3))
        for joint, angle in list(zip(body.joints(g.kind), angles))[::-1]:
            point = _turned(point, np.asarray(joint.axis, float), np.asarray(joint.point, float), angle)
        offset[:, g.kind] = np.einsum("nij,nj->ni", R0, point)
        half = 0.5 * float(np.linalg.norm(hi - lo)) * (1 + 1e-9)
        radius[:, g.kind] = half + g.bound_rate(0.0, turn, dturret, dgun)
    return GroupSpheres(offset, radius)


def _turned(points: np.ndarray, axis: np.ndarray, through: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Points (N, 3) turned by ``angle`` (N,) rad about the line through ``through`` along ``axis``
    (right hand, as ``geometry.motion.axis_rotation``), by Rodrigues' formula."""
    u = axis / np.linalg.norm(axis)
    v = points - through
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    # u x v by its components (np.cross's products and differences, without its axis shuffling)
    cross = np.empty_like(v)
    cross[:, 0] = u[1] * v[:, 2] - u[2] * v[:, 1]
    cross[:, 1] = u[2] * v[:, 0] - u[0] * v[:, 2]
    cross[:, 2] = u[0] * v[:, 1] - u[1] * v[:, 0]
    return v * c + cross * s + (v @ u)[:, None] * u * (1 - c) + through


CLEAR_BLOCK = 2048  # spans a block of ``clear_spans``: its (B, 3, 3) arrays stay in cache


def clear_spans(spheres_a: GroupSpheres, a_t0, a_t1, a_c0, a_c1, spheres_b: GroupSpheres, b_t0, b_t1, b_c0,
                b_c1, u0, u1) -> np.ndarray:
    """(P,) bool: the common span [u0, u1] (P,) s of segment a and segment b is proven free of any
    contact between the two vehicles. Per side: its spheres (P rows), its segment's time span t0, t1
    (P,) s and hull origin c0, c1 (P, 3) m at its ends. False wherever the proof does not hold."""
    u0 = np.asarray(u0, dtype=float)
    u1 = np.asarray(u1, dtype=float)

    def origin(t0, t1, c0, c1):
        t0 = np.asarray(t0, float)
        length = np.asarray(t1, float) - t0
        v = np.where(length[:, None] > 0, (c1 - c0) / np.where(length > 0, length, 1.0)[:, None], 0.0)
        return c0 + (u0 - t0)[:, None] * v, v

    pa, va = origin(a_t0, a_t1, np.asarray(a_c0, float), np.asarray(a_c1, float))
    pb, vb = origin(b_t0, b_t1, np.asarray(b_c0, float), np.asarray(b_c1, float))
    p0 = pa - pb  # (P, 3): the origins' difference at u0
    vel = va - vb
    vv = (vel[:, 0] * vel[:, 0] + vel[:, 1] * vel[:, 1]) + vel[:, 2] * vel[:, 2]
    moving = vv > 0
    inv = np.where(moving, 1.0 / np.where(moving, vv, 1.0), 0.0)
    span = np.maximum(u1 - u0, 0.0)
    clear = np.ones(len(u0), dtype=bool)
    for k in range(0, len(u0), CLEAR_BLOCK):  # blocks: every group pair at once, the block in cache
        b = slice(k, k + CLEAR_BLOCK)
        # (B, 3 of a's groups, 3 of b's), a coordinate at a time
        d0 = [(p0[b, c, None, None] + spheres_a.offset[b, :, None, c]) - spheres_b.offset[b, None, :, c]
              for c in range(3)]
        v = [vel[b, c, None, None] for c in range(3)]
        # the least |d0 + tau vel| over tau in [0, span]: the convex quadratic's minimiser, clipped
        tau = np.clip(-((d0[0] * v[0] + d0[1] * v[1]) + d0[2] * v[2]) * inv[b, None, None], 0.0,
                      span[b, None, None])
        d = [d0[c] + tau * v[c] for c in range(3)]
        least2 = (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]
        reach = (spheres_a.radius[b, :, None] + spheres_b.radius[b, None, :]) + MARGIN
        present = ~np.isnan(reach)  # an absent group (NaN radius) never decides
        clear[b] = ((least2 > np.where(present, reach, 0.0) ** 2) | ~present).all(axis=(1, 2))
    return clear


@dataclass(frozen=True)
class StretchSpheres:
    """Each of V vehicles' group spheres over a stretch of time: the vehicle's line (its origin at
    ``t0``, ``c0`` (V,), (V, 3) and at ``t1``, ``c1``: where its segments begin and end in the
    stretch), and spheres about the line, offset (V, 3, 3) from it, radius (V, 3) m (NaN for a group
    the body has not): ``clear_spans`` takes them as each vehicle's one segment."""

    t0: np.ndarray
    t1: np.ndarray
    c0: np.ndarray
    c1: np.ndarray
    spheres: GroupSpheres


def stretch_spheres(owner: np.ndarray, n: int, spheres: GroupSpheres, t0, t1, c0, c1, w0: float,
                    w1: float) -> StretchSpheres:
    """The spheres of n vehicles over the stretch [w0, w1] from their segments in it: owner (M,) the
    vehicle (0..n-1) of each segment, its spheres (``group_spheres``), time span t0, t1 (M,) s and
    hull origin c0, c1 (M, 3) m at its ends.

    Proof. A vehicle's line L(t) runs through its origin where its first segment in the stretch
    begins and where its last one ends (any line would do: it decides the bound's tightness, not its
    truth). On segment k (clipped to the stretch: [a, b]) the origin c(t) moves at constant velocity,
    so c(t) - L(t) is affine there and its length, convex, is largest at a or b: E, the largest
    over the segments' ends, bounds |c(t) - L(t)| wherever the vehicle moves. Group g lies in the
    sphere of radius r_kg about o_kg + c(t) (``group_spheres``), so in the sphere of radius
    r_kg + |o_kg - o_g| + E about o_g + L(t), o_g the first segment's offset: the sphere of the
    largest of these radii over the segments holds the group throughout the stretch, about a centre
    moving on a straight line at constant velocity: what ``clear_spans`` proves apart."""
    owner = np.asarray(owner, dtype=np.int64)
    t0 = np.asarray(t0, float)
    t1 = np.asarray(t1, float)
    c0 = np.asarray(c0, float)
    c1 = np.asarray(c1, float)
    length = t1 - t0
    vel = np.where(length[:, None] > 0, (c1 - c0) / np.where(length > 0, length, 1.0)[:, None], 0.0)
    a = np.clip(t0, w0, w1)
    b = np.clip(t1, a, w1)
    ca = c0 + (a - t0)[:, None] * vel
    cb = c0 + (b - t0)[:, None] * vel
    # each vehicle's first segment (earliest a) and last (latest b)
    order = np.lexsort((a, owner))
    first = order[np.r_[True, owner[order][1:] != owner[order][:-1]]]
    order = np.lexsort((b, owner))
    last = order[np.r_[owner[order][1:] != owner[order][:-1], True]]
    lt0 = np.zeros(n)
    lt1 = np.zeros(n)
    lc0 = np.zeros((n, 3))
    lc1 = np.zeros((n, 3))
    lt0[owner[first]], lc0[owner[first]] = a[first], ca[first]
    lt1[owner[last]], lc1[owner[last]] = b[last], cb[last]
    span = lt1 - lt0
    lvel = np.where(span[:, None] > 0, (lc1 - lc0) / np.where(span > 0, span, 1.0)[:, None], 0.0)

    def off_line(t, c):
        return np.linalg.norm(c - (lc0[owner] + (t - lt0[owner])[:, None] * lvel[owner]), axis=1)

    dev = np.maximum(off_line(a, ca), off_line(b, cb))
    far = np.zeros(n)
    np.maximum.at(far, owner, dev)
    offset = np.zeros((n, SLOTS, 3))
    offset[owner[first]] = spheres.offset[first]
    grown = spheres.radius + np.linalg.norm(spheres.offset - offset[owner], axis=2)
    radius = np.full((n, SLOTS), -np.inf)
    np.maximum.at(radius, owner, grown)  # NaN (an absent group) stays NaN
    radius = radius + far[:, None] * (1 + 1e-9) + 1e-9
    return StretchSpheres(lt0, lt1, lc0, lc1, GroupSpheres(offset, radius))
