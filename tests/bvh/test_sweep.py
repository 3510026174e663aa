"""The first contact along a motion: closed forms, exact rationals, the dense-sampling oracle, invariances."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.threads import get_num_threads, set_num_threads
from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.sweep import (
    LEAF_BOUND,
    Joint,
    chain_placements,
    chain_placements_naive,
    first_contacts,
    first_contacts_sampled,
    motion_rows,
    static_rows,
)
from tankcd_cli.geometry.motion import quaternion_slerp, rotation_angle
from tankcd_cli.geometry.pose import quaternion_from_euler
from tankcd_cli.geometry.triangles import tri_distance
from tankcd_cli.vehicle_mesh import box

IDENTITY = np.array([[1.0, 0.0, 0.0, 0.0]])


def _yaw(deg):
    deg = np.atleast_1d(np.asarray(deg, dtype=float))
    return quaternion_from_euler(np.zeros_like(deg), np.zeros_like(deg), np.radians(deg))


def _translation(c0, c1):
    return motion_rows(IDENTITY, [c0], IDENTITY, [c1])


def test_a_box_driving_into_a_wall_touches_at_gap_over_speed():
    cube = build_tree(box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]), k=18)
    wall = build_tree(box([5.0, -2.0, -2.0], [5.2, 2.0, 2.0]), k=18)
    rows, joints = _translation([0, 0, 0], [10, 0, 0])  # 10 m over the step
    still, none = static_rows(1)
    got = first_contacts(cube, wall, rows, joints, still, none, np.array([10.0]))
    assert got.found[0]
    gap, speed = 4.5, 10.0
    # the leaf's middle lies within half a leaf after the true time (no point moves LEAF_BOUND in
    # half a leaf), or earlier where the box already passes within 2 LEAF_BOUND of the wall
    assert gap / speed - 2 * LEAF_BOUND / speed <= got.s[0] <= (gap + LEAF_BOUND) / speed
    assert got.points[0, 0] == pytest.approx(5.0, abs=2 * LEAF_BOUND)


def test_the_same_box_stopping_short_of_the_wall_touches_nothing():
    cube = build_tree(box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]), k=18)
    wall = build_tree(box([5.0, -2.0, -2.0], [5.2, 2.0, 2.0]), k=18)
    rows, joints = _translation([0, 0, 0], [4.5 - 0.0015, 0, 0])  # ends 1.5 mm short
    still, none = static_rows(1)
    assert not first_contacts(cube, wall, rows, joints, still, none, np.array([4.5])).found[0]


def test_tunnelling_through_a_thin_wall_between_the_ends_is_found():
    # both ends clear of a 0.2 m wall; a fixed-step check with 1 m steps would miss it
    cube = build_tree(box([-0.1, -0.1, -0.1], [0.1, 0.1, 0.1]), k=18)
    wall = build_tree(box([5.0, -2.0, -2.0], [5.2, 2.0, 2.0]), k=18)
    rows, joints = _translation([0, 0, 0], [15, 0, 0])
    still, none = static_rows(1)
    got = first_contacts(cube, wall, rows, joints, still, none, np.array([15.0]))
    assert got.found[0] and got.s[0] == pytest.approx(4.9 / 15, abs=2 * LEAF_BOUND / 15)


def test_a_bar_pivoting_in_place_reaches_a_post_at_the_angle_of_the_geometry():
    bar = build_tree(box([-0.1, -0.1, -0.1], [3.0, 0.1, 0.1]), k=18)
    post = build_tree(box([1.9, 1.9, -1.0], [2.1, 2.1, 1.0]), k=18)
    rows, joints = motion_rows(_yaw(0), [[0, 0, 0]], _yaw(100), [[0, 0, 0]])
    still, none = static_rows(1)
    rate = np.radians(100) * np.hypot(3.0, 0.1) * (1 + 1e-9)
    got = first_contacts(bar, post, rows, joints, still, none, np.array([rate]))
    # the bar's leading face (y = 0.1 in its frame) meets the post's corner (2.1, 1.9):
    # -2.1 sin(a) + 1.9 cos(a) = 0.1
    from scipy.optimize import brentq

    angle = np.degrees(brentq(lambda a: -2.1 * np.sin(a) + 1.9 * np.cos(a) - 0.1, 0.3, 1.2))
    assert got.found[0]
    assert got.s[0] * 100 == pytest.approx(angle, abs=np.degrees(2 * LEAF_BOUND / 2.1) + 1e-9)


def _exact_translation_time(P, v, Q):
    """Earliest s in [0, 1] at which triangle P + s v (integer coordinates) first meets Q, as a Fraction:
    the least of every vertex-face and edge-edge crossing time that lies on both features."""
    P = [[Fraction(int(c)) for c in p] for p in P]
    Q = [[Fraction(int(c)) for c in q] for q in Q]
    v = [Fraction(int(c)) for c in v]

    def sub(a, b):
        return [a[i] - b[i] for i in range(3)]

    def dot(a, b):
        return sum(a[i] * b[i] for i in range(3))

    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]

    def inside(p, T):
        n = cross(sub(T[1], T[0]), sub(T[2], T[0]))
        return all(dot(cross(sub(T[(k + 1) % 3], T[k]), sub(p, T[k])), n) >= 0 for k in range(3))

    times = []
    for moving, tri, sign in ((P, Q, 1), (Q, P, -1)):  # a vertex of one against the other's face
        n = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]))
        w = [sign * c for c in v]
        if dot(n, w) == 0:
            continue
        for p in moving:
            s = dot(n, sub(tri[0], p)) / dot(n, w)
            if 0 <= s <= 1 and inside([p[i] + s * w[i] for i in range(3)], tri):
                times.append(s)
    for i in range(3):  # edge against edge: the moving edge's line meets the other's at s
        a, b = P[i], P[(i + 1) % 3]
        for j in range(3):
            c, d = Q[j], Q[(j + 1) % 3]
            n = cross(sub(b, a), sub(d, c))
            if dot(n, v) == 0:
                continue
            s = dot(n, sub(c, a)) / dot(n, v)
            if not 0 <= s <= 1:
                continue
            a2 = [a[k] + s * v[k] for k in range(3)]
            b2 = [b[k] + s * v[k] for k in range(3)]
            e, f = sub(b2, a2), sub(d, c)
            ee, ff, ef = dot(e, e), dot(f, f), dot(e, f)
            den = ee * ff - ef * ef
            if den == 0:
                continue
            r = sub(a2, c)
            u = (ef * dot(f, r) - ff * dot(e, r)) / den
            w_ = (ee * dot(f, r) - ef * dot(e, r)) / den
            if 0 <= u <= 1 and 0 <= w_ <= 1:
                times.append(s)
    return min(times) if times else None


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(-6, 6), min_size=9, max_size=9), st.lists(st.integers(-6, 6), min_size=9, max_size=9),
       st.lists(st.integers(-20, 20), min_size=3, max_size=3))
def test_translation_contact_times_equal_the_exact_rationals(p, q, v):
    P = np.array(p, float).reshape(3, 3)
    Q = np.array(q, float).reshape(3, 3) + [0, 0, 3]
    if np.linalg.norm(np.cross(P[1] - P[0], P[2] - P[0])) == 0 or np.linalg.norm(np.cross(Q[1] - Q[0], Q[2] - Q[0])) == 0:
        return
    if tri_distance(P, Q)[0] == 0:
        return  # touching at the start: the first contact is at 0
    speed = float(np.linalg.norm(v))
    if speed == 0:
        return
    exact = _exact_translation_time(P, v, Q)
    rows, joints = _translation([0, 0, 0], v)
    still, none = static_rows(1)
    got = first_contacts(build_tree(P[None], k=18), build_tree(Q[None], k=18), rows, joints, still, none,
                         np.array([speed]))
    if exact is None:
        # no contact: a report is allowed only as a pass within 2 LEAF_BOUND
        if got.found[0]:
            s = got.s[0]
            assert tri_distance(P + s * np.array(v, float), Q)[0] <= 2 * LEAF_BOUND + 1e-9
        return
    assert got.found[0]
    # never later than half a leaf after the true first contact, and if earlier, only because the
    # triangles already pass within 2 LEAF_BOUND there
    assert got.s[0] <= float(exact) + LEAF_BOUND / speed + 1e-12
    if got.s[0] < float(exact) - 2 * LEAF_BOUND / speed:
        assert tri_distance(P + got.s[0] * np.array(v, float), Q)[0] <= 2 * LEAF_BOUND + 1e-9


def _random_motion(rng, n, spin_deg=120.0, reach=4.0):
    q0 = quaternion_from_euler(*np.radians(rng.uniform(-30, 30, (3, n))))
    angles = np.radians(rng.uniform(-spin_deg, spin_deg, (3, n)))
    q1 = quaternion_from_euler(*angles)
    c0 = rng.uniform(-reach, reach, (n, 3))
    c1 = c0 + rng.uniform(-reach, reach, (n, 3))
    return q0, c0, q1, c1


def _rate(rows, radius):
    angle = rotation_angle(rows[:, 0:4], rows[:, 7:11])
    return np.linalg.norm(rows[:, 11:14] - rows[:, 4:7], axis=1) + angle * radius


def test_against_the_dense_sampling_oracle_on_random_motions():
    rng = np.random.default_rng(7)
    A = box([-1.0, -0.4, -0.3], [1.0, 0.4, 0.3])
    B = box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5])
    ta, tb = build_tree(A, k=18, leaf_size=2), build_tree(B, k=18, leaf_size=2)
    n, step = 30, 3e-3
    q0, c0, q1, c1 = _random_motion(rng, n, reach=2.0)
    rows, joints = motion_rows(q0, c0, q1, c1)
    still, none = static_rows(n)
    rate = _rate(rows, np.linalg.norm([1.0, 0.4, 0.3])) * (1 + 1e-9)
    got = first_contacts(ta, tb, rows, joints, still, none, rate)
    first, least = first_contacts_sampled(A, B, rows, joints, still, none, rate, step=step)
    for q in range(n):
        if least[q] == 0:  # the oracle saw them meet: never missed, and never reported late
            assert got.found[q]
            assert got.s[q] <= first[q] + LEAF_BOUND / rate[q] + 1e-12
        if got.found[q]:  # a report is a real near-contact: within 1 mm (and the oracle's step)
            assert least[q] <= 2 * LEAF_BOUND + step
        if least[q] > 2 * LEAF_BOUND + step:
            assert not got.found[q]
    assert got.found.any() and not got.found.all()


def test_joints_turn_parts_as_the_chain_says_and_the_compiled_chain_agrees():
    rng = np.random.default_rng(3)
    n = 50
    q0, c0, q1, c1 = _random_motion(rng, n)
    turret = Joint((-0.35, 0.0, 0.0), (0.0, 0.0, 1.0))
    gun = Joint((0.10, 0.0, 1.75), (0.0, -1.0, 0.0))
    a0, da = rng.uniform(-np.pi, np.pi, (2, n)), rng.uniform(-2, 2, (2, n))
    rows, joints = motion_rows(q0, c0, q1, c1, (turret, gun), a0, da)
    s = rng.uniform(0, 1, n)
    R, t = chain_placements_naive(rows, joints, s)
    Rc, tc = chain_placements(rows, joints, s)
    np.testing.assert_allclose(Rc, R, atol=1e-12)
    np.testing.assert_allclose(tc, t, atol=1e-9)
    # the gun's muzzle, by hand: hull placement, then the turret turn, then the elevation
    from tankcd_cli.geometry.motion import axis_rotation, quaternion_matrix

    muzzle = np.array([6.1, 0.0, 1.75])
    H = quaternion_matrix(quaternion_slerp(q0, q1, s))
    c = c0 + s[:, None] * (c1 - c0)
    for i in range(5):
        az, el = a0[0, i] + s[i] * da[0, i], a0[1, i] + s[i] * da[1, i]
        p = np.array(gun.point) + axis_rotation(gun.axis, el) @ (muzzle - gun.point)
        p = np.array(turret.point) + axis_rotation(turret.axis, az) @ (p - turret.point)
        np.testing.assert_allclose(R[i] @ muzzle + t[i], H[i] @ p + c[i], atol=1e-9)


def test_invariances_splitting_reversing_and_swapping_the_moving_body():
    rng = np.random.default_rng(11)
    A = box([-1.0, -0.4, -0.3], [1.0, 0.4, 0.3])
    B = box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5])
    ta, tb = build_tree(A, k=18, leaf_size=2), build_tree(B, k=18, leaf_size=2)
    n = 60
    q0, c0, _, c1 = _random_motion(rng, n, reach=2.0)
    q1 = q0  # pure translation: splitting and reversing have closed forms
    rows, joints = motion_rows(q0, c0, q1, c1)
    still, none = static_rows(n)
    rate = np.linalg.norm(c1 - c0, axis=1)
    whole = first_contacts(ta, tb, rows, joints, still, none, rate)
    # split at 0.5: the first contact is in the first half, or else in the second
    mid = 0.5 * (c0 + c1)
    h1 = first_contacts(ta, tb, *motion_rows(q0, c0, q0, mid), still, none, rate / 2)
    h2 = first_contacts(ta, tb, *motion_rows(q0, mid, q0, c1), still, none, rate / 2)
    split = np.where(h1.found, 0.5 * h1.s, 0.5 + 0.5 * h2.s)
    tol = 2 * LEAF_BOUND / np.maximum(rate, 1e-9) * 2

    def alike(found, s, q_s=None):
        """The same verdicts as the whole step, but where the motion only grazes within 1 mm (where
        either verdict is right), and the same first times."""
        differ = np.flatnonzero(found != whole.found)
        if len(differ):
            _, least = first_contacts_sampled(A, B, rows[differ], joints[differ], still[differ], none[differ],
                                              rate[differ], step=5e-4)
            assert (least <= 2 * LEAF_BOUND + 5e-4).all()
        both = found & whole.found
        if s is not None and both.any():
            np.testing.assert_allclose(s[both], whole.s[both], atol=tol[both].max())

    alike(h1.found | h2.found, split)
    # reversed: a motion that meets B meets it backwards too
    back = first_contacts(ta, tb, *motion_rows(q1, c1, q0, c0), still, none, rate)
    alike(back.found, None)
    # swapped: B moving by the inverse placement against A standing still meets A at the same time
    moving_b = first_contacts(tb, ta, *_inverse_rows(q0, c0, c1), still, none, rate)
    alike(moving_b.found, moving_b.s)


def _inverse_rows(q, c0, c1):
    """Motion rows of the inverse placement of a translation with fixed attitude q: x -> R^T (x - c)."""
    from tankcd_cli.geometry.motion import quaternion_matrix

    qi = q * [1, -1, -1, -1]
    R = quaternion_matrix(q)
    return motion_rows(qi, -np.einsum("nji,nj->ni", R, c0), qi, -np.einsum("nji,nj->ni", R, c1))


def test_both_bodies_moving_head_on_add_their_bounds():
    # two boxes closing head-on, each at 5 m per step: a signed bound would cancel; the absolute sum does not
    cube = build_tree(box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]), k=18)
    rows_a, ja = _translation([0, 0, 0], [5, 0, 0])
    rows_b, jb = _translation([10, 0, 0], [5, 0, 0])
    got = first_contacts(cube, cube, rows_a, ja, rows_b, jb, np.array([10.0]))
    assert got.found[0] and got.s[0] == pytest.approx(0.9, abs=2 * LEAF_BOUND / 10)
    assert got.points[0, 0] == pytest.approx(5.0, abs=2 * LEAF_BOUND)  # the faces meet at x = 0.5 + 4.5


def test_same_answers_on_one_and_two_threads():
    rng = np.random.default_rng(5)
    A = box([-1.0, -0.4, -0.3], [1.0, 0.4, 0.3], 2)
    ta, tb = build_tree(A, k=18), build_tree(box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5], 2), k=18)
    n = 200
    rows, joints = motion_rows(*_random_motion(rng, n, reach=2.0))
    still, none = static_rows(n)
    rate = _rate(rows, np.linalg.norm([1.0, 0.4, 0.3])) * (1 + 1e-9)
    threads = get_num_threads()
    try:
        set_num_threads(1)
        one = first_contacts(ta, tb, rows, joints, still, none, rate)
        set_num_threads(2)
        two = first_contacts(ta, tb, rows, joints, still, none, rate)
    finally:
        set_num_threads(threads)
    for name in ("found", "s", "pairs", "points", "node_tests", "levels"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))


def test_the_sweep_and_the_pose_walk_agree_on_still_poses():
    """Both walks drop pairs of nodes with one shared k-DOP test (bvh/_trees.pxd): a body held still
    at a pose meets the other in the sweep wherever the pose walk finds triangles crossing, and
    the sweep's other reports are within its leaf bound (brute force over every triangle pair)."""
    from tankcd_cli.bvh.query import collide

    rng = np.random.default_rng(11)
    A = box([-1.0, -0.4, -0.3], [1.0, 0.4, 0.3])
    B = np.concatenate([box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]), box([2.0, -0.2, -1.0], [2.3, 0.2, 1.0])])
    ta, tb = build_tree(A, k=18, leaf_size=2), build_tree(B, k=18, leaf_size=2)
    n = 120
    q = quaternion_from_euler(*np.radians(rng.uniform(-90, 90, (3, n))))
    c = rng.uniform(-2.5, 3.5, (n, 3)) * [1, 0.6, 0.6]
    rows, joints = motion_rows(q, c, q, c)
    still, none = static_rows(n)
    swept = first_contacts(ta, tb, rows, joints, still, none, np.zeros(n))
    R, t = chain_placements_naive(rows, joints, np.zeros(n))
    posed = collide(ta, tb, R, t)
    assert posed.hit.any() and not posed.hit.all()
    assert swept.found[posed.hit].all()  # crossing at the pose: the sweep meets it at once
    for k in np.flatnonzero(swept.found & ~posed.hit):
        placed = A @ R[k].T + t[k]
        least = min(tri_distance(P, Q)[0] for P in placed for Q in B)
        assert least <= 2 * LEAF_BOUND
    assert not swept.found.all()


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_property_a_bound_on_the_fraction_changes_only_answers_at_or_after_it(seed):
    """With ``before``, a query whose first contact (without it) lies before its bound gets that
    answer bit for bit (time, pair, point); any other gets none or one at or after its bound; and
    no query does more node tests. Bounds: 0, the contact's own fraction, a hair either side of it,
    random ones, 1 and infinity; still queries (rate 0) among the moving ones."""
    rng = np.random.default_rng(seed)
    A = box([-1.0, -0.4, -0.3], [1.0, 0.4, 0.3], 2)
    ta, tb = build_tree(A, k=18, leaf_size=2), build_tree(box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5], 2), k=18)
    n = 60
    rows, joints = motion_rows(*_random_motion(rng, n, reach=2.0))
    rows[: n // 6, 7:14] = rows[: n // 6, 0:7]  # still: the end pose is the start pose
    still, none = static_rows(n)
    rate = _rate(rows, np.linalg.norm([1.0, 0.4, 0.3])) * (1 + 1e-9)
    free = first_contacts(ta, tb, rows, joints, still, none, rate)
    s = np.where(free.found, free.s, rng.uniform(0, 1, n))
    choice = rng.integers(0, 7, n)
    before = np.select([choice == 0, choice == 1, choice == 2, choice == 3, choice == 4, choice == 5],
                       [np.zeros(n), s, np.nextafter(s, 2), np.nextafter(s, -1), rng.uniform(0, 1, n),
                        np.ones(n)], np.inf)
    got = first_contacts(ta, tb, rows, joints, still, none, rate, before=before)
    same = free.found & (free.s < before)
    for name in ("found", "s", "pairs", "points"):
        np.testing.assert_array_equal(getattr(got, name)[same], getattr(free, name)[same])
    assert (~got.found[~same] | (got.s[~same] >= before[~same])).all()
    assert (got.node_tests <= free.node_tests).all()
    assert free.found.any()
    with pytest.raises(ValueError, match="NaN"):
        first_contacts(ta, tb, rows, joints, still, none, rate, before=np.full(n, np.nan))
