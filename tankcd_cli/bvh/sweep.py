"""The first contact of two trees along rigid, articulated motions over one time step.

A body's motion over a step (fraction s from 0 to 1) is a chain G(s) = H(s) o J1(s) o J2(s):
H turns its frame from quaternion q0 to q1 at a constant angular velocity (slerp) while its
origin moves from c0 to c1 along a straight line; each joint J turns the part about a fixed axis
through a fixed point (in the frame before the earlier joints turn it) by an angle changing at
a constant rate (a turret about its ring's axis, a gun about its trunnion). An obstacle is a body
whose motion is the identity.

Method: a bound rate B (m per unit of s) such that no point of either body moves more than
B |w - u| between fractions u and w (``geometry.motion`` proves one for the vehicle's parts:
translation plus rotation times the largest radius, per joint its angle times its radius, summed
in absolute value for both bodies). Then on any sub-interval [lo, hi] with middle m and half
width h, every point of each body stays within h B_body of where it is at m, so the two bodies
can meet somewhere in [lo, hi] only if at m they come within r = h B of each other. The walk at
m asks exactly that: the tandem tree walk of A (seen in B's frame at m) against B with every
volume grown by r (a k-DOP of unit slab directions grows by r per slab when grown by a ball of
radius r) and, at two leaves, the exact triangle-triangle distance against r.

Bisection, earliest half first: a sub-interval whose walk finds nothing within r holds no
contact and is dropped; one that does is halved, until its r is at most ``eps`` (0.5 mm by
default), where the query reports the sub-interval's middle as the time of first contact.

Guarantees (proof): (1) never missed: if the bodies touch at s*, every sub-interval containing
s* passes its walk (the touching points are within h B of their places at the middle, so some
triangles are within r), so the bisection reaches a leaf around s* or an earlier one, and
reports. (2) A reported leaf is a real near-contact: at its middle two triangles are within
r <= eps, and over the leaf no point moves more than eps, so the bodies come within 2 eps
(1 mm) of each other there: "a pass within 1 mm may count as a contact". (3) The time: the
earliest leaf reported lies no later than the leaf around the first true contact, so its middle
is at most half a leaf after it, and within half a leaf no point of either body travels more
than eps: the time is right to 0.5 mm of travel (docs/formats.md#motion-between-rows).
Nothing is sampled: a contact that begins and ends between two samples of any fixed step is
found all the same, and a pass more than 2 eps from the obstacle at every instant is never
reported.

``first_contacts_sampled`` is the dense-sampling oracle the tests compare with: placements at
so many fractions that no point moves more than a given step between two, and the brute-force
triangle distance at each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.bvh._sweep import chain_placements  # noqa: F401 (the compiled chain, for the callers)
from tankcd_cli.bvh._sweep import first_contacts as kernel
from tankcd_cli.bvh.build import Tree
from tankcd_cli.geometry import kdop
from tankcd_cli.geometry.motion import axis_rotation, quaternion_matrix, quaternion_slerp
from tankcd_cli.geometry.triangles import tri_distance

MOTION_WIDTH = 30
PASS_SECONDS = 60e-6  # a moving query's bisection, about (two vehicles' hulls near each other)
STILL_SECONDS = 4e-6  # an instant's query (one walk), about
PARALLEL_ABOVE = 0.02  # s of estimated work: below it the batch runs on one thread
LEAF_BOUND = 5e-4
"""m. A sub-interval whose two bodies move no more than this (each point, from its place at the
middle) is a leaf: within it the pair counts as touching if at its middle it is this close."""


@dataclass(frozen=True)
class Joint:
    """A turning part: the fixed point (3,) and unit axis (3,) it turns about, in the body's frame as
    it is before any earlier joint of the chain turns (m; the angle is right-handed about the axis)."""

    point: tuple
    axis: tuple


def motion_rows(q0, c0, q1, c1, joints: tuple = (), angle0=(), dangle=()) -> tuple[np.ndarray, np.ndarray]:
    """Motion rows (N, 30) and joint counts (N,) for N steps of one kind of body.

    q0, q1 : (N, 4) start and end attitude (qw, qx, qy, qz); c0, c1 : (N, 3) start and end origin, m
    joints : the body's joints (at most 2), outermost first (a gun's chain: the turret, then the gun)
    angle0, dangle : per joint, (N,) start angle and change over the step, rad
    """
    q0, q1 = np.atleast_2d(np.asarray(q0, dtype=float)), np.atleast_2d(np.asarray(q1, dtype=float))
    c0, c1 = np.atleast_2d(np.asarray(c0, dtype=float)), np.atleast_2d(np.asarray(c1, dtype=float))
    n = len(q0)
    if len(joints) > 2:
        raise ValueError("a motion has at most two joints")
    rows = np.zeros((n, MOTION_WIDTH))
    rows[:, 0:4], rows[:, 4:7], rows[:, 7:11], rows[:, 11:14] = q0, c0, q1, c1
    for k, joint in enumerate(joints):
        base = 14 + 8 * k
        axis = np.asarray(joint.axis, dtype=float)
        rows[:, base:base + 3] = joint.point
        rows[:, base + 3:base + 6] = axis / np.linalg.norm(axis)
        rows[:, base + 6] = angle0[k]
        rows[:, base + 7] = dangle[k]
    return rows, np.full(n, len(joints), dtype=np.int64)


def static_rows(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Motion rows of a body that does not move (an obstacle placed in the world)."""
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    z = np.zeros((n, 3))
    return motion_rows(q, z, q, z)


def chain_placements_naive(rows: np.ndarray, joints: np.ndarray, s) -> tuple[np.ndarray, np.ndarray]:
    """(R (N, 3, 3), t (N, 3)) of motion rows at fractions s (N,), in numpy: the oracle of the compiled
    ``chain_placements`` (the same definition, written independently)."""
    rows = np.atleast_2d(rows)
    s = np.broadcast_to(np.asarray(s, dtype=float), (len(rows),))
    q = quaternion_slerp(rows[:, 0:4], rows[:, 7:11], s)
    H = quaternion_matrix(q)
    c = rows[:, 4:7] + s[:, None] * (rows[:, 11:14] - rows[:, 4:7])
    R = np.tile(np.eye(3), (len(rows), 1, 1))
    t = np.zeros((len(rows), 3))
    for k in (1, 0):  # the last joint turns first
        base = 14 + 8 * k
        use = joints > k
        if not use.any():
            continue
        for i in np.flatnonzero(use):
            J = axis_rotation(rows[i, base + 3:base + 6], rows[i, base + 6] + s[i] * rows[i, base + 7])
            p = rows[i, base:base + 3]
            R[i], t[i] = J @ R[i], J @ (t[i] - p) + p
    return np.einsum("nij,njk->nik", H, R), np.einsum("nij,nj->ni", H, t) + c


@dataclass
class FirstContacts:
    """Per query: found (N,) bool, s (N,) the fraction of first contact (NaN where none), pairs (N, 2)
    input triangle indices (moving, other), points (N, 3) world contact points, node_tests (N,),
    levels (N,) the deepest bisection level."""

    found: np.ndarray
    s: np.ndarray
    pairs: np.ndarray
    points: np.ndarray
    node_tests: np.ndarray
    levels: np.ndarray


def first_contacts(moving: Tree, other: Tree, rows_a, joints_a, rows_b, joints_b, rate,
                   eps: float = LEAF_BOUND, before=None) -> FirstContacts:
    """The first contact of ``moving`` (motion rows_a) with ``other`` (motion rows_b) in each of N
    steps; ``rate`` (N,) bounds how far any point of either body moves per unit of s, summed
    (m). See the module's docstring for the method and its guarantees.

    ``before`` (N,) fractions, optional: the caller keeps only contacts earlier than these (it has
    one of another pair of parts there). A query whose first contact lies before its bound gets the
    same answer as without it; any other gets none, or one at or after its bound, for less work
    (the bisection drops the sub-intervals that can only report there)."""
    if moving.k != other.k:
        raise ValueError(f"both trees need the same k-DOP type (got k = {moving.k} and {other.k})")
    d = kdop.directions(moving.k)
    W = kdop.triple_inverses(moving.k)
    # threads only for a batch worth waking them for: on a busy machine a parallel region waits for
    # its threads to be scheduled (up to a time slice, milliseconds), more than a small batch's work
    rate = np.asarray(rate, dtype=np.float64)
    work = PASS_SECONDS * np.count_nonzero(rate > eps) + STILL_SECONDS * np.count_nonzero(rate <= eps)
    found, s, pairs, points, node_tests, levels = kernel(moving, other, d, W, rows_a, joints_a, rows_b, joints_b,
                                                         rate, float(eps), work > PARALLEL_ABOVE, before)
    return FirstContacts(found.astype(bool), np.where(found > 0, s, np.nan), pairs, points, node_tests, levels)


def first_contacts_sampled(moving_triangles: np.ndarray, other_triangles: np.ndarray, rows_a, joints_a, rows_b,
                           joints_b, rate, step: float = 1e-3, within: float = 0.0, exact_below: float = 0.01):
    """The oracle: each query's placements at fractions so close that no point moves more than
    ``step`` m between two (from ``rate``), the least distance between the two triangle sets at
    each (brute force over all pairs; where the sets' boxes are more than ``exact_below`` apart,
    the boxes' gap, a lower bound). Returns (first fraction (N,) at which the distance is at most
    ``within``, NaN where never; least distance over the step (N,))."""
    rows_a, rows_b = np.atleast_2d(rows_a), np.atleast_2d(rows_b)
    n = len(rows_a)
    first = np.full(n, np.nan)
    least = np.full(n, np.inf)
    for q in range(n):
        samples = int(np.ceil(rate[q] / step)) + 1 if rate[q] > 0 else 1
        s = np.linspace(0.0, 1.0, samples + 1)
        Ra, ta = chain_placements_naive(np.repeat(rows_a[q:q + 1], len(s), 0), np.repeat(joints_a[q:q + 1], len(s)), s)
        Rb, tb = chain_placements_naive(np.repeat(rows_b[q:q + 1], len(s), 0), np.repeat(joints_b[q:q + 1], len(s)), s)
        for i, si in enumerate(s):
            A = moving_triangles @ Ra[i].T + ta[i]
            B = other_triangles @ Rb[i].T + tb[i]
            gap = np.linalg.norm(np.maximum(np.maximum(A.min(axis=(0, 1)) - B.max(axis=(0, 1)),
                                                       B.min(axis=(0, 1)) - A.max(axis=(0, 1))), 0))
            d = gap if gap > exact_below else min(tri_distance(P, Q)[0] for P in A for Q in B)
            least[q] = min(least[q], d)
            if d <= within and np.isnan(first[q]):
                first[q] = si
    return first, least
