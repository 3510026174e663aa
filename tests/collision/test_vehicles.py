"""Vehicle against vehicle, both moving: head-on closed forms, a dense oracle, symmetry."""

import numpy as np
import pytest

from tankcd_cli.bvh.sweep import LEAF_BOUND
from tankcd_cli.collision.vehicle_body import group_placements, vehicle_body
from tankcd_cli.collision.vehicles import SpanMotion, first_vehicle_contacts
from tankcd_cli.geometry.motion import quaternion_matrix, quaternion_slerp
from tankcd_cli.geometry.pose import quaternion_from_euler
from tankcd_cli.vehicle import vehicle_preset
from tankcd_cli.vehicle_mesh import PARTS, box, vehicle_mesh

T72 = vehicle_preset("t72")


def _body(boxy=False):
    if boxy:
        hull = box([-3.43, -1.73, 0.49], [3.43, 1.73, 2.19])
        return vehicle_body(T72, hull, np.zeros(len(hull), int), ("hull",))
    tris, parts = vehicle_mesh(T72, 2)
    return vehicle_body(T72, tris, parts, PARTS)


def _q(yaw_deg):
    yaw = np.radians(np.atleast_1d(np.asarray(yaw_deg, float)))
    return quaternion_from_euler(np.zeros_like(yaw), np.zeros_like(yaw), yaw)


def _motion(c0, c1, yaw0=0.0, yaw1=None, turret0=0.0, dturret=0.0, gun0=0.0, dgun=0.0):
    c0, c1 = np.atleast_2d(np.asarray(c0, float)), np.atleast_2d(np.asarray(c1, float))
    n = len(c0)
    yaw1 = yaw0 if yaw1 is None else yaw1
    return SpanMotion(_q(np.broadcast_to(yaw0, n)), c0, _q(np.broadcast_to(yaw1, n)), c1,
                      np.broadcast_to(np.radians(turret0), n).astype(float),
                      np.broadcast_to(np.radians(dturret), n).astype(float),
                      np.broadcast_to(np.radians(gun0), n).astype(float), np.broadcast_to(np.radians(dgun), n).astype(float))


def test_two_hulls_head_on_meet_at_the_closed_form_time_and_speed():
    body = _body(boxy=True)
    # a at 8 m/s east from x = 0, b at 7 m/s west from x = 20, over one second: fronts 3.43 m ahead
    a = _motion([0, 0, 0], [8, 0, 0])
    b = _motion([20, 0, 0], [13, 0, 0], yaw0=180.0)
    hits = first_vehicle_contacts(body, a, body, b)
    t = (20 - 2 * 3.43) / 15.0
    assert hits.span.tolist() == [0]
    assert hits.s[0] == pytest.approx(t, abs=LEAF_BOUND / 15.0 + 1e-12)
    assert hits.point[0, 0] == pytest.approx(8 * t + 3.43, abs=2 * LEAF_BOUND)
    assert hits.closing[0] == pytest.approx(15.0, rel=1e-6)  # per second here: the span is 1 s
    # the same motions the other way round: the same time and point
    back = first_vehicle_contacts(body, b, body, a)
    assert back.s[0] == pytest.approx(hits.s[0], abs=LEAF_BOUND / 15.0) and back.closing[0] == pytest.approx(15.0)


def test_a_convoy_nose_to_tail_and_a_column_side_by_side_do_not_touch():
    body = _body()
    # 1 m between the rear of one hull and the muzzle of the gun behind it, all at 10 m/s
    gap_ahead = 6.1 + 3.43 + 1.0
    a = _motion([0, 0, 0], [10, 0, 0])
    b = _motion([gap_ahead, 0, 0], [gap_ahead + 10, 0, 0])
    assert len(first_vehicle_contacts(body, a, body, b).span) == 0
    # side by side, 10 cm between the hull sides (3.46 m wide hulls)
    c = _motion([0, 3.46 + 0.1, 0], [10, 3.46 + 0.1, 0])
    assert len(first_vehicle_contacts(body, a, body, c).span) == 0


def test_a_crossing_whose_overlap_lasts_a_fraction_of_the_span_is_found():
    body = _body(boxy=True)
    # b crosses a's path at 20 m/s; the two hulls overlap for about 0.2 of the 1 s span
    a = _motion([0, 0, 0], [2, 0, 0])
    b = _motion([1, -12, 0], [1, 8, 0], yaw0=90.0)
    hits = first_vehicle_contacts(body, a, body, b)
    assert hits.span.tolist() == [0]
    # b's front reaches a's side (y = -1.73) when -12 + 20 s + 3.43 = -1.73
    assert hits.s[0] == pytest.approx((12 - 3.43 - 1.73) / 20, abs=LEAF_BOUND / 20 + 1e-9)


def _dense(body, ma, mb, samples=1600):
    """The oracle: both bodies placed at many fractions of each span, every group pair tested at every
    sample by the discrete tree query (``bvh.query.collide``, itself held to the brute force of every
    triangle pair in tests/bvh/test_query.py); the first sample in contact, or NaN."""
    from tankcd_cli.bvh.query import collide

    first = np.full(len(ma), np.nan)
    s = np.linspace(0, 1, samples + 1)
    for k in range(len(ma)):
        placed = []
        for m in (ma, mb):
            q = quaternion_slerp(np.repeat(m.q0[k:k + 1], len(s), 0), np.repeat(m.q1[k:k + 1], len(s), 0), s)
            c = m.c0[k] + s[:, None] * (m.c1[k] - m.c0[k])
            placed.append((quaternion_matrix(q), c, m.turret0[k] + s * m.dturret[k], m.gun0[k] + s * m.dgun[k]))
        hit = np.zeros(len(s), dtype=bool)
        for ga in body.groups:
            Ra, ta = group_placements(body, ga, placed[0][0], placed[0][1], placed[0][2], placed[0][3])
            for gb in body.groups:
                Rb, tb = group_placements(body, gb, placed[1][0], placed[1][1], placed[1][2], placed[1][3])
                # a's group in b's group's frame: x -> Rb^T (Ra x + ta - tb)
                R = np.einsum("nji,njk->nik", Rb, Ra)
                t = np.einsum("nji,nj->ni", Rb, ta - tb)
                hit |= collide(ga.tree, gb.tree, R, t).found > 0
        if hit.any():
            first[k] = s[np.argmax(hit)]
    return first


def _random_pairs(rng, n, apart):
    """n random pairs of articulated vehicles near each other: a's hull origins within 3 m of 0, b's
    within ``apart`` m of a's (both at z = 0), each driving up to 6 m, turning, its turret and gun turning
    (b's gun from 2 deg, by -6 deg). Returns the start origins (n, 3) each and the two motions."""
    c0a = np.column_stack([rng.uniform(-3, 3, (n, 2)), np.zeros(n)])
    c0b = c0a + np.column_stack([rng.uniform(-apart, apart, (n, 2)), np.zeros(n)])
    a = _motion(c0a, c0a + np.column_stack([rng.uniform(-6, 6, (n, 2)), np.zeros(n)]), rng.uniform(-180, 180, n),
                rng.uniform(-180, 180, n), rng.uniform(-180, 180, n), rng.uniform(-90, 90, n))
    b = _motion(c0b, c0b + np.column_stack([rng.uniform(-6, 6, (n, 2)), np.zeros(n)]), rng.uniform(-180, 180, n),
                rng.uniform(-180, 180, n), rng.uniform(-180, 180, n), rng.uniform(-90, 90, n), 2.0, -6.0)
    return c0a, c0b, a, b


def test_against_the_dense_oracle_on_random_pairs_of_articulated_vehicles():
    rng = np.random.default_rng(8)
    body = _body()
    n = 40
    _, _, a, b = _random_pairs(rng, n, 12)
    hits = first_vehicle_contacts(body, a, body, b)
    found = dict(zip(hits.span.tolist(), hits.s.tolist()))
    dense = _dense(body, a, b)
    assert np.isfinite(dense).any() and not np.isfinite(dense).all()
    rate = np.array([a.rate(g) for g in body.groups]).min(axis=0) + np.array([b.rate(g) for g in body.groups]).min(axis=0)
    for k in range(n):
        if np.isfinite(dense[k]):  # never missed; never after the oracle's first sample in contact (but half a leaf)
            assert k in found and found[k] <= dense[k] + LEAF_BOUND / rate[k] + 1e-12
    assert len(set(found) - set(np.flatnonzero(np.isfinite(dense)).tolist())) <= 1  # passes within 1 mm only


def test_the_point_of_a_first_contact_along_a_segment_or_a_face_is_its_centre_whatever_a_micrometre_changes():
    """Two box hulls: b's vertical front-left edge meets a's flat left side (the contact a vertical segment,
    0.49 to 2.19 m high), and two fronts meet flat (a face, offset 1 m sideways). The sweep meets any
    triangle pair of the segment or face first; the point reported is the centre of all the pairs within
    1 mm: on the segment near its middle (z = 1.34) and in the overlap near its centre, the same to 1 cm
    whatever the micrometres."""
    body = _body(boxy=True)
    rng = np.random.default_rng(4)
    points = []
    for trial in range(12):
        e = rng.uniform(-1e-6, 1e-6, 6)
        # b, turned 45 deg, drives north onto a's left side (y = +1.73) with its right-front corner first
        a = _motion([0, 0, 0], [0, e[0], 0])
        b = _motion([1.0 + e[1], 8.0 + e[2], 0], [1.0 + e[1], 2.0 + e[2], 0], yaw0=-135.0 + e[3])
        hits = first_vehicle_contacts(body, a, body, b)
        assert hits.span.tolist() == [0]
        points.append(hits.point[0])
    points = np.array(points)
    assert np.ptp(points, axis=0).max() < 0.01
    # on the segment, near its middle (the mean of the ends and of where the triangles' diagonals cross it)
    assert points[:, 2].mean() == pytest.approx((0.49 + 2.19) / 2, abs=0.05)
    assert points[:, 1].mean() == pytest.approx(1.73, abs=0.01)
    faces = []
    for trial in range(12):
        e = rng.uniform(-1e-6, 1e-6, 4)
        a = _motion([0, 0, 0], [4 + e[0], 0, 0])
        b = _motion([12, 1.0 + e[1], 0], [8 + e[2], 1.0 + e[1], 0], yaw0=180.0 + e[3])
        hits = first_vehicle_contacts(body, a, body, b)
        faces.append(hits.point[0])
    faces = np.array(faces)
    assert np.ptp(faces, axis=0).max() < 0.01
    # the fronts' overlap: y from 1.0 - 1.73 to 1.73, z from 0.49 to 2.19: its centre
    assert faces[0, 1] == pytest.approx(0.5, abs=0.1) and faces[0, 2] == pytest.approx(1.34, abs=0.1)



def _centre_of_all_pairs(body, ma, mb, k, s):
    """The oracle of a contact's point: every triangle of both bodies placed at fraction s of span k (no
    group left out), every pair's 15 feature pairs by the numpy twins (no box or plane test; pairs whose
    bounding spheres are more than 1 cm apart skipped), those within ``CONTACT_BAND`` of the least, each
    midpoint once (to 1 um): their mean."""
    from tankcd_cli.collision.contact_pairs import triangle_pair_features_numpy
    from tankcd_cli.collision.vehicles import CONTACT_BAND

    placed = []
    for m in (ma, mb):
        q = quaternion_slerp(m.q0[k:k + 1], m.q1[k:k + 1], np.array([s]))
        c = m.c0[k:k + 1] + s * (m.c1[k:k + 1] - m.c0[k:k + 1])
        tris = []
        for g in body.groups:
            R, t = group_placements(body, g, quaternion_matrix(q), c, m.turret0[k:k + 1] + s * m.dturret[k:k + 1],
                                    m.gun0[k:k + 1] + s * m.dgun[k:k + 1])
            tris.append(g.tree.triangles @ R[0].T + t[0])
        placed.append(np.concatenate(tris))
    A, B = placed
    # only pairs whose bounding spheres (about the centroids) come within 1 cm: a lower bound of the
    # distance, independent of the search's boxes and planes
    ca, cb = A.mean(axis=1), B.mean(axis=1)
    ra, rb = np.linalg.norm(A - ca[:, None], axis=2).max(axis=1), np.linalg.norm(B - cb[:, None], axis=2).max(axis=1)
    gap = np.linalg.norm(ca[:, None] - cb[None], axis=2) - ra[:, None] - rb[None]
    ia, ib = np.nonzero(gap <= 0.01)
    d, cp, cq = triangle_pair_features_numpy(A[ia], B[ib])
    d = np.where(np.isfinite(d), d, np.inf)
    keep = d <= d.min() + CONTACT_BAND
    mids = np.unique(np.round(0.5 * (cp[keep] + cq[keep]), 6), axis=0)
    return mids.mean(axis=0)


def test_the_point_of_a_first_contact_is_the_centre_of_every_pair_within_the_band_of_all_triangles():
    """Random articulated pairs (turrets and guns turning): each contact's point equals the centre the
    oracle finds from every triangle pair of the two whole bodies, so the groups and pairs the search
    leaves out (boxes or planes more than its reach apart) never held a pair within the band."""
    rng = np.random.default_rng(21)
    body = _body()
    n = 24
    _, _, a, b = _random_pairs(rng, n, 10)
    hits = first_vehicle_contacts(body, a, body, b)
    assert len(hits.span) >= 8
    parts = set()
    for h, k in enumerate(hits.span):
        want = _centre_of_all_pairs(body, a, b, k, hits.s[h])
        assert np.allclose(hits.point[h], want, atol=1e-5), (k, hits.point[h], want)
        parts.add((body.part_names[hits.part_a[h]], body.part_names[hits.part_b[h]]))
    assert len(parts) >= 3  # hulls, turrets and guns among the contacts, not one pair of groups


def test_asked_only_whether_they_touch_the_query_gives_the_same_spans_times_and_parts():
    """``describe=False`` (whether two vehicles touch, as at a span's start) skips the contact's point
    and closing speed only: the same spans, fractions and parts as the full answer, on moving and on
    still (an instant's) random articulated pairs."""
    rng = np.random.default_rng(23)
    body = _body()
    n = 30
    c0a, c0b, a, b = _random_pairs(rng, n, 9)
    still_a = _motion(c0a, c0a, a_yaw := rng.uniform(-180, 180, n), a_yaw, rng.uniform(-180, 180, n))
    still_b = _motion(c0b, c0b, b_yaw := rng.uniform(-180, 180, n), b_yaw, rng.uniform(-180, 180, n))
    for ma, mb in ((a, b), (still_a, still_b)):
        full = first_vehicle_contacts(body, ma, body, mb)
        bare = first_vehicle_contacts(body, ma, body, mb, describe=False)
        assert len(full.span) >= 3
        for f in ("span", "s", "part_a", "part_b"):
            assert np.array_equal(getattr(full, f), getattr(bare, f))
        assert (bare.closing == 0).all() and bare.queries == full.queries
