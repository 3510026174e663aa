"""Vehicle against vehicle along their motions: the first contact of two moving, articulated bodies.

Both vehicles move over a common time span as the motion model says (``geometry.motion``): each
hull rigidly (its origin on a straight line, its attitude turning at a constant rate), its turret
and gun at constant rates. A ``SpanMotion`` holds one vehicle's motion over each of M spans (the
caller cuts each vehicle's rigid sub-steps to the spans where both exist and both move rigidly:
a rigid step cut to part of its time is still one). ``first_vehicle_contacts`` walks every group
of one vehicle against every group of the other with both moving (``bvh.sweep``: the two bodies'
motion bounds summed in absolute value, so bodies closing head-on never cancel), and returns the
earliest contact per span with both parts, the point and the closing speed there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.bvh.sweep import chain_placements, first_contacts, motion_rows
from tankcd_cli.collision.contact_pairs import near_triangle_pairs, triangle_pair_features
from tankcd_cli.collision.vehicle_body import VehicleBody, group_of
from tankcd_cli.geometry.motion import rotation_angle


@dataclass(frozen=True)
class SpanMotion:
    """One vehicle's motion over M spans: hull attitude q0 -> q1 (M, 4) and origin c0 -> c1 (M, 3),
    turret and gun angles turret0, gun0 (M,) rad changing by dturret, dgun over the span."""

    q0: np.ndarray
    c0: np.ndarray
    q1: np.ndarray
    c1: np.ndarray
    turret0: np.ndarray
    dturret: np.ndarray
    gun0: np.ndarray
    dgun: np.ndarray

    def __len__(self) -> int:
        return len(self.q0)

    def take(self, idx) -> "SpanMotion":
        return SpanMotion(*(getattr(self, f)[idx] for f in self.__dataclass_fields__))

    def rows(self, body: VehicleBody, group) -> tuple[np.ndarray, np.ndarray]:
        """The sweep's motion rows (M, 30) and joint counts of one of the body's groups."""
        return motion_rows(self.q0, self.c0, self.q1, self.c1, body.joints(group.kind),
                           (self.turret0, self.gun0)[:group.kind], (self.dturret, self.dgun)[:group.kind])

    def rate(self, group) -> np.ndarray:
        """How far any point of ``group`` moves per unit of the span's fraction, at most (m)."""
        return group.bound_rate(np.linalg.norm(self.c1 - self.c0, axis=1), rotation_angle(self.q0, self.q1),
                                self.dturret, self.dgun)


@dataclass
class VehicleHits:
    """Per span with a contact: span index, the fraction s of first contact, each vehicle's part
    (index into its body's ``part_names``), the world contact point and the closing speed there
    (m per unit of s: divide by the span's length in seconds for m/s)."""

    span: np.ndarray
    s: np.ndarray
    part_a: np.ndarray
    part_b: np.ndarray
    point: np.ndarray
    closing: np.ndarray
    queries: int


def first_vehicle_contacts(body_a: VehicleBody, motion_a: SpanMotion, body_b: VehicleBody,
                           motion_b: SpanMotion, describe: bool = True) -> VehicleHits:
    """The earliest contact in each span between vehicle a and vehicle b, both moving.

    Broad phase per group pair: each group's box at the span's middle grown by half its motion
    bound holds it throughout the span, so a pair of groups whose grown boxes miss costs that
    test alone; the rest take the sweep with both bodies moving. ``describe`` False: which spans
    hold a contact, when, and the parts the sweep met, without the contact's point (the sweep's
    own pair's, not ``contact_centres``') or its closing speed (zeros): for a caller that asks
    whether the vehicles touch."""
    m = len(motion_a)
    best_s = np.full(m, np.inf)
    part_a = np.full(m, -1, dtype=np.int64)
    part_b = np.full(m, -1, dtype=np.int64)
    point = np.full((m, 3), np.nan)
    queries = 0
    if m == 0:
        return VehicleHits(np.zeros(0, np.int64), np.zeros(0), part_a, part_b, point, np.zeros(0), 0)
    half = np.full(m, 0.5)
    prepared = {}
    for side, body, motion in (("a", body_a, motion_a), ("b", body_b, motion_b)):
        for g in body.groups:
            rows, joints = motion.rows(body, g)
            rate = motion.rate(g)
            R, t = chain_placements(rows, joints, half)
            centre = 0.5 * (g.tree.lo[0, :3] + g.tree.hi[0, :3])
            extent = 0.5 * (g.tree.hi[0, :3] - g.tree.lo[0, :3])
            mid = np.einsum("nij,j->ni", R, centre) + t
            grown = np.einsum("nij,j->ni", np.abs(R), extent) + 0.5 * rate[:, None]
            prepared[side, g.kind] = (g, rows, joints, rate, mid - grown, mid + grown)
    for ga in body_a.groups:
        for gb in body_b.groups:
            g1, rows_a, ja, rate_a, lo_a, hi_a = prepared["a", ga.kind]
            g2, rows_b, jb, rate_b, lo_b, hi_b = prepared["b", gb.kind]
            near = np.flatnonzero(((lo_a <= hi_b) & (lo_b <= hi_a)).all(axis=1))
            if len(near) == 0:
                continue
            queries += len(near)
            # a span's contact of an earlier pair of groups bounds what this pair must look for
            got = first_contacts(g1.tree, g2.tree, rows_a[near], ja[near], rows_b[near], jb[near],
                                 rate_a[near] + rate_b[near], before=best_s[near])
            hit = np.flatnonzero(got.found)
            k = near[hit]
            better = got.s[hit] < best_s[k]
            k, h = k[better], hit[better]
            best_s[k] = got.s[h]
            part_a[k] = g1.parts[got.pairs[h, 0]]
            part_b[k] = g2.parts[got.pairs[h, 1]]
            point[k] = got.points[h]
    span = np.flatnonzero(np.isfinite(best_s))
    if not describe:
        return VehicleHits(span, best_s[span], part_a[span], part_b[span], point[span], np.zeros(len(span)), queries)
    moving = span[_moves(motion_a, span) | _moves(motion_b, span)]  # an instant's test: its point is not asked
    point[moving] = contact_centres(body_a, motion_a, body_b, motion_b, moving, best_s[moving], point[moving])
    closing = _closing_speed(body_a, motion_a, body_b, motion_b, span, best_s[span], part_a[span], part_b[span],
                             point[span])
    return VehicleHits(span, best_s[span], part_a[span], part_b[span], point[span], closing, queries)


CONTACT_BAND = 1e-3
"""m. The triangle pairs of a first contact: those within this of the closest pair (the sweep's own
"a pass within 1 mm may count")."""


def contact_centres(body_a: VehicleBody, motion_a: SpanMotion, body_b: VehicleBody, motion_b: SpanMotion,
                    span: np.ndarray, s: np.ndarray, witness: np.ndarray) -> np.ndarray:
    """The point of each first contact (K, 3): both bodies placed at the contact's fraction ``s``, every
    pair of their triangles within ``CONTACT_BAND`` of the closest pair, the mean of each pair's
    closest points' midpoint.

    Why not the sweep's own point (``witness``): that is the pair its walk met first, and where the
    first contact is a segment or a patch (a vertical hull side against another's edge, two faces
    meeting flat) any pair along it may be met first: a change of the input by a micrometre moves
    that point along the whole segment (0.22 m seen on two T-72 hulls, 2.24 m reported). The pairs
    within the band are all of the segment or patch and do not change with such a change (a pair
    enters or leaves the band only at 1 mm of gap); of each, every feature pair (vertex against
    triangle, edge against edge) within the band is taken, each point once (rounded to 1 um), so a
    segment gives its ends and a patch its corners: their mean is what the motion defines, to well
    within 1 cm.
    ``witness`` is kept where no pair is found (the placements at ``s`` no longer within the band)."""
    out = np.array(witness, dtype=np.float64, copy=True)
    if len(span) == 0:
        return out
    reach = 2 * CONTACT_BAND + 1e-3  # the sweep's pair lies within 1 mm; the band's pairs within 1 mm of it
    s = np.asarray(s, dtype=np.float64)
    sides = []
    for body, motion in ((body_a, motion_a), (body_b, motion_b)):
        groups = []
        for g in body.groups:
            rows, joints = motion.take(span).rows(body, g)
            R, t = chain_placements(rows, joints, s)
            centre = 0.5 * (g.tree.lo[0, :3] + g.tree.hi[0, :3])
            extent = 0.5 * (g.tree.hi[0, :3] - g.tree.lo[0, :3])
            mid = np.einsum("nij,j->ni", R, centre) + t
            half = np.einsum("nij,j->ni", np.abs(R), extent)
            groups.append((g, R, t, mid - half, mid + half))  # the group's world box at s (K, 3) each
        sides.append(groups)
    # only groups whose boxes come within reach can hold a near pair (a triangle's box lies in its
    # group's; 1 um more than reach for the two computations' roundings): the same pairs, fewer placed
    slack = reach + 1e-6
    near = {(x, y): np.flatnonzero(((ga[3] <= gb[4] + slack) & (gb[3] <= ga[4] + slack)).all(axis=1))
            for x, ga in enumerate(sides[0]) for y, gb in enumerate(sides[1])}
    placed = [{}, {}]
    for side, groups in enumerate(sides):
        for x, (g, R, t, _, _) in enumerate(groups):
            want = np.zeros(len(span), dtype=bool)
            for key, idx in near.items():
                if key[side] == x:
                    want[idx] = True
            use = np.flatnonzero(want)
            if len(use):
                pos = np.cumsum(want) - 1  # a span's row among those placed
                tri = np.matmul(g.tree.triangles.reshape(1, -1, 3), np.transpose(R[use], (0, 2, 1))) + t[use, None, :]
                placed[side][x] = (use, pos, tri.reshape(len(use), -1, 3, 3))  # world, at s
    owners, Ps, Qs = [], [], []
    for (x, y), idx in near.items():
        if len(idx) == 0:
            continue
        use_a, pos_a, A = placed[0][x]
        use_b, pos_b, B = placed[1][y]
        A = A if len(use_a) == len(idx) else A[pos_a[idx]]
        B = B if len(use_b) == len(idx) else B[pos_b[idx]]
        o, ia, ib = near_triangle_pairs(A, B, reach, planes=True)  # pairs apart by a plane cannot be within reach
        owners.append(idx[o])
        Ps.append(A[o, ia])
        Qs.append(B[o, ib])
    owner = np.concatenate(owners) if owners else np.zeros(0, dtype=np.int64)
    if len(owner) == 0:
        return out
    P, Q = np.concatenate(Ps), np.concatenate(Qs)
    # every hit's pairs in one call
    d, cp, cq = triangle_pair_features(P, Q)
    d = np.where(np.isfinite(d), d, np.inf)
    least = np.full(len(span), np.inf)
    np.minimum.at(least, owner, d.min(axis=1))
    # every feature pair within the band (a segment's two ends, a patch's corners), each point once
    keep = d <= (least[owner] + CONTACT_BAND)[:, None]
    rows = np.nonzero(keep)
    who = owner[rows[0]]
    mids = np.round(0.5 * (cp[rows] + cq[rows]), 6)
    key = np.unique(np.column_stack([who, mids]), axis=0)  # per hit, each point once
    hit = key[:, 0].astype(np.int64)
    count = np.bincount(hit, minlength=len(span))
    total = np.stack([np.bincount(hit, weights=key[:, 1 + c], minlength=len(span)) for c in range(3)], axis=1)
    done = count > 0
    out[done] = total[done] / count[done, None]
    return out


def _moves(motion: SpanMotion, span: np.ndarray) -> np.ndarray:
    """(K,) bool: the motion over these spans is not the identity (an instant's placement)."""
    return ((motion.c0[span] != motion.c1[span]).any(axis=1) | (motion.q0[span] != motion.q1[span]).any(axis=1)
            | (motion.dturret[span] != 0) | (motion.dgun[span] != 0))


def _closing_speed(body_a, motion_a, body_b, motion_b, span, s, part_a, part_b, point) -> np.ndarray:
    """|velocity of the contact point as part of a - as part of b| at the first contact, per unit of s:
    each vehicle's group placement at s and a little later, the point carried by each."""
    if len(span) == 0:
        return np.zeros(0)

    ds = 1e-4
    velocity = []
    for body, motion, part in ((body_a, motion_a, part_a), (body_b, motion_b, part_b)):
        v = np.zeros((len(span), 3))
        kinds = np.array([_group_kind(body, p) for p in part])
        for g in body.groups:
            sel = np.flatnonzero(kinds == g.kind)
            if len(sel) == 0:
                continue
            rows, joints = motion.take(span[sel]).rows(body, g)
            R0, t0 = chain_placements(rows, joints, s[sel])
            R1, t1 = chain_placements(rows, joints, np.minimum(s[sel] + ds, 1.0))
            step = np.minimum(s[sel] + ds, 1.0) - s[sel]
            local = np.einsum("nji,nj->ni", R0, point[sel] - t0)  # the point in the group's own frame
            later = np.einsum("nij,nj->ni", R1, local) + t1
            v[sel] = (later - point[sel]) / np.where(step > 0, step, 1.0)[:, None]
        velocity.append(v)
    return np.linalg.norm(velocity[0] - velocity[1], axis=1)


def _group_kind(body: VehicleBody, part: int) -> int:
    return group_of(body.part_names[part])
