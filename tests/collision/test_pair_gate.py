"""The gate of the checks between vehicles: it never proves clear a span in which the exact narrow
phase (``first_vehicle_contacts``, gates not involved) finds a contact, on random pairs of random
rigid motions, and it does prove clear what is plainly far (or it would be no gate)."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tankcd_cli.collision.pair_gate import GroupSpheres, clear_spans, group_spheres
from tankcd_cli.collision.vehicle_body import vehicle_body
from tankcd_cli.collision.vehicles import first_vehicle_contacts
from tankcd_cli.geometry.pose import quaternion_from_euler
from tankcd_cli.replay.between_rows import Segments
from tankcd_cli.replay.effects.vehicles import _cut, _still
from tankcd_cli.vehicle import vehicle_preset
from tankcd_cli.vehicle_mesh import PARTS, vehicle_mesh

_BODIES = {}


def _body(name):
    if name not in _BODIES:
        preset = vehicle_preset(name)
        tris, parts = vehicle_mesh(preset, 2)
        _BODIES[name] = vehicle_body(preset, tris, parts, PARTS)
    return _BODIES[name]


def _segments(rng, n, near=None, reach=14.0):
    """n random rigid segments: a random time span, origin moving up to 6 m, yaw turning up to 40 deg
    (with some roll and pitch), turret up to 180 deg and gun up to 20 deg; origins within ``reach``
    of ``near`` where given."""
    t0 = rng.uniform(0, 1, n)
    t1 = t0 + rng.choice([0.0, 0.05, 0.5, 2.0], n) * rng.uniform(0.2, 1, n)
    c0 = rng.uniform(-reach, reach, (n, 3)) * [1, 1, 0.05]
    if near is not None:
        c0 = c0 + near
    c1 = c0 + rng.normal(0, 2.5, (n, 3)) * [1, 1, 0.05] * rng.choice([0, 1], (n, 1))
    yaw0 = rng.uniform(-180, 180, n)
    yaw1 = yaw0 + rng.uniform(-40, 40, n) * rng.choice([0, 1], n)
    tilt = rng.uniform(-8, 8, (n, 2, 2)) * rng.choice([0, 1], (n, 1, 1))
    q0 = quaternion_from_euler(np.radians(tilt[:, 0, 0]), np.radians(tilt[:, 0, 1]), np.radians(yaw0))
    q1 = quaternion_from_euler(np.radians(tilt[:, 1, 0]), np.radians(tilt[:, 1, 1]), np.radians(yaw1))
    turret0 = rng.uniform(-np.pi, np.pi, n)
    dturret = rng.uniform(-np.pi, np.pi, n) * rng.choice([0, 1], n)
    gun0 = rng.uniform(-0.1, 0.3, n)
    dgun = rng.uniform(-0.3, 0.3, n) * rng.choice([0, 1], n)
    return Segments(np.arange(n), np.arange(n), t0, t1, q0, c0, q1, c1, turret0, dturret, gun0, dgun,
                    np.zeros(n, bool))


def _verdicts(body_a, a, body_b, b):
    """The gate's verdict and the exact check's, per pair (segment k of a with segment k of b, over
    their common span): (clear (P,), touches (P,), the common spans' (u0, u1))."""
    u0 = np.maximum(a.t0, b.t0)
    u1 = np.minimum(a.t1, b.t1)
    both = np.flatnonzero(u1 >= u0)
    u0, u1 = u0[both], u1[both]
    a, b = a.take(both), b.take(both)
    ga = group_spheres(body_a, a.q0, a.c0, a.q1, a.turret0, a.dturret, a.gun0, a.dgun)
    gb = group_spheres(body_b, b.q0, b.c0, b.q1, b.turret0, b.dturret, b.gun0, b.dgun)
    clear = clear_spans(ga, a.t0, a.t1, a.c0, a.c1, gb, b.t0, b.t1, b.c0, b.c1, u0, u1)
    idx = np.arange(len(u0))
    ma, mb = _cut(a, idx, u0, u1), _cut(b, idx, u0, u1)
    touches = np.zeros(len(u0), bool)
    touches[first_vehicle_contacts(body_a, ma, body_b, mb).span] = True
    touches[first_vehicle_contacts(body_a, _still(ma, idx), body_b, _still(mb, idx)).span] = True
    return clear, touches, (u0, u1)


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([("t72", "t72"), ("t72", "m1"), ("m1", "t72")]),
       st.sampled_from([8.0, 14.0, 22.0]))
@example(7, ("t72", "t72"), 14.0)
def test_the_gate_never_clears_a_span_the_exact_check_finds_a_contact_in(seed, kinds, reach):
    rng = np.random.default_rng(seed)
    n = 160
    a = _segments(rng, n, reach=reach)
    b = _segments(rng, n, near=a.c0, reach=reach)
    clear, touches, _ = _verdicts(_body(kinds[0]), a, _body(kinds[1]), b)
    assert not (clear & touches).any(), f"cleared spans with a contact: {np.flatnonzero(clear & touches)}"
    # the property can fail: the random pairs hold contacts, and far pairs the gate proves clear
    if reach <= 14.0:
        assert touches.any()
    if reach >= 14.0:
        assert clear.any()


def test_a_turret_swinging_its_gun_into_a_neighbour_is_not_cleared():
    # two T-72s abreast 7 m apart standing still, a's turret swinging 90 deg to its left: the gun
    # (above the hulls) meets b's turret; the gate must leave the span to the narrow phase. With the
    # turret still (gun forward) nothing touches
    body = _body("t72")
    q = quaternion_from_euler(np.zeros(2), np.zeros(2), np.zeros(2))
    seg = Segments(np.arange(2), np.arange(2), np.zeros(2), np.ones(2), q, np.array([[0, 0, 0], [0, 7.0, 0]]), q,
                   np.array([[0, 0, 0], [0, 7.0, 0]]), np.zeros(2), np.array([np.pi / 2, 0]), np.zeros(2),
                   np.zeros(2), np.zeros(2, bool))
    a, b = seg.take([0]), seg.take([1])
    clear, touches, _ = _verdicts(body, a, body, b)
    assert touches.tolist() == [True] and clear.tolist() == [False]
    still = Segments(*(getattr(a, f) for f in Segments.__dataclass_fields__))
    still.dturret[:] = 0
    clear, touches, _ = _verdicts(body, still, body, b)
    assert touches.tolist() == [False]


def test_a_platoon_abreast_is_cleared_whatever_its_speed_and_a_head_on_pair_is_not():
    # four T-72s 12 m abreast at 20 m/s for 2 s: the relative motion is nil, every pair proven clear;
    # two driving at each other from 60 m apart at 20 m/s each meet within the 2 s: not cleared
    body = _body("t72")
    n = 4
    q = quaternion_from_euler(np.zeros(n), np.zeros(n), np.zeros(n))
    c0 = np.column_stack([np.zeros(n), 12.0 * np.arange(n), np.zeros(n)])
    c1 = c0 + [40.0, 0, 0]
    z = np.zeros(n)
    seg = Segments(np.arange(n), np.arange(n), z, z + 2.0, q, c0, q, c1, z, z, z, z, np.zeros(n, bool))
    i, j = np.triu_indices(n, 1)
    clear, touches, _ = _verdicts(body, seg.take(i), body, seg.take(j))
    assert clear.all() and not touches.any()
    q2 = quaternion_from_euler(np.zeros(2), np.zeros(2), np.radians([0.0, 180.0]))
    c0 = np.array([[0.0, 0, 0], [60.0, 0, 0]])
    c1 = np.array([[40.0, 0, 0], [20.0, 0, 0]])
    head = Segments(np.arange(2), np.arange(2), np.zeros(2), np.full(2, 2.0), q2, c0, q2, c1, np.zeros(2),
                    np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2, bool))
    clear, touches, _ = _verdicts(body, head.take([0]), body, head.take([1]))
    assert touches.tolist() == [True] and clear.tolist() == [False]


def test_a_body_without_a_group_is_gated_on_the_groups_it_has():
    # a hull-only body (no turret, no gun): its absent groups' spheres are NaN and never decide
    from tankcd_cli.vehicle_mesh import box

    preset = vehicle_preset("t72")
    hull = box([-3.43, -1.73, 0.49], [3.43, 1.73, 2.19])
    boxy = vehicle_body(preset, hull, np.zeros(len(hull), int), ("hull",))
    g = group_spheres(boxy, *(np.array(v) for v in ([[1.0, 0, 0, 0]], [[0.0, 0, 0]], [[1.0, 0, 0, 0]], [0.0],
                                                    [0.0], [0.0], [0.0])))
    assert np.isnan(g.radius[0, 1:]).all() and g.radius[0, 0] == pytest.approx(np.linalg.norm([3.43, 1.73, 0.85]))
    far = GroupSpheres(g.offset, g.radius)
    c = np.zeros((1, 3))
    ok = clear_spans(far, [0.0], [1.0], c, c, far, [0.0], [1.0], c + [7.9, 0, 0], c + [7.9, 0, 0], [0.0], [1.0])
    near = clear_spans(far, [0.0], [1.0], c, c, far, [0.0], [1.0], c + [7.0, 0, 0], c + [7.0, 0, 0], [0.0], [1.0])
    assert ok.tolist() == [True] and near.tolist() == [False]


def test_segments_starting_at_different_times_are_taken_where_their_common_span_begins():
    # a drives at 20 m/s from x = -20 over [0, 2] s; b's segment begins at 1 s at x = 0, 3 m to a's left,
    # at a's speed: side by side (hulls overlapping) over the whole common span [1, 2]
    body = _body("t72")
    q = quaternion_from_euler(np.zeros(2), np.zeros(2), np.zeros(2))
    z = np.zeros(2)
    seg = Segments(np.arange(2), np.arange(2), np.array([0.0, 1.0]), np.array([2.0, 2.0]), q,
                   np.array([[-20.0, 0, 0], [0, 3.0, 0]]), q, np.array([[20.0, 0, 0], [20.0, 3.0, 0]]), z, z, z, z,
                   np.zeros(2, bool))
    clear, touches, (u0, u1) = _verdicts(body, seg.take([0]), body, seg.take([1]))
    assert (u0.tolist(), u1.tolist()) == ([1.0], [2.0])
    assert touches.tolist() == [True] and clear.tolist() == [False]


def test_the_group_centres_are_where_group_placements_puts_the_boxes_centres():
    # the gate turns each box centre by Rodrigues' formula; group_placements (matrices) is the reference
    from tankcd_cli.collision.vehicle_body import group_placements
    from tankcd_cli.geometry.motion import quaternion_matrix

    rng = np.random.default_rng(4)
    seg = _segments(rng, 50)
    body = _body("t72")
    got = group_spheres(body, seg.q0, seg.c0, seg.q1, seg.turret0, seg.dturret, seg.gun0, seg.dgun)
    for g in body.groups:
        R, t = group_placements(body, g, quaternion_matrix(seg.q0), seg.c0, seg.turret0, seg.gun0)
        centre = np.einsum("nij,j->ni", R, 0.5 * (g.tree.lo[0, :3] + g.tree.hi[0, :3])) + t
        np.testing.assert_allclose(got.offset[:, g.kind] + seg.c0, centre, atol=1e-9)


def _paths(rng, vehicles, steps, w0, w1, reach):
    """Each vehicle's motion over [w0, w1] as a chain of rigid segments (its rows: positions, yaw,
    turret and gun joined end to end, each row interval its own segment), some starting before w0
    or ending after w1: Segments with entity the vehicle."""
    parts = []
    for v in range(vehicles):
        t = np.sort(rng.uniform(w0 - 0.5, w1 + 0.5, steps + 1))
        c = np.cumsum(rng.normal(0, 1.5, (steps + 1, 3)) * [1, 1, 0.03], axis=0) + rng.uniform(-reach, reach, 3) * [
            1, 1, 0]
        yaw = np.cumsum(rng.normal(0, 15, steps + 1)) + rng.uniform(-180, 180)
        q = quaternion_from_euler(np.zeros(steps + 1), np.radians(rng.normal(0, 3, steps + 1)), np.radians(yaw))
        turret = np.cumsum(rng.normal(0, 0.5, steps + 1)) * rng.choice([0, 1])
        gun = np.clip(np.cumsum(rng.normal(0, 0.05, steps + 1)), -0.1, 0.3)
        k = np.arange(steps)
        parts.append(Segments(np.full(steps, v), k, t[k], t[k + 1], q[k], c[k], q[k + 1], c[k + 1], turret[k],
                              turret[k + 1] - turret[k], gun[k], gun[k + 1] - gun[k], np.zeros(steps, bool)))
    return Segments.join(parts)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([6.0, 12.0, 40.0]))
@example(1, 40.0)
def test_a_pair_of_vehicles_cleared_over_a_window_has_no_contact_in_any_of_its_spans(seed, reach):
    from tankcd_cli.collision.pair_gate import stretch_spheres

    rng = np.random.default_rng(seed)
    w0, w1 = 4.0, 6.0
    body = _body("t72")
    n = 6
    seg = _paths(rng, n, 8, w0, w1, reach)
    seg = seg.take(np.flatnonzero((seg.t1 >= w0) & (seg.t0 <= w1)))
    spheres = group_spheres(body, seg.q0, seg.c0, seg.q1, seg.turret0, seg.dturret, seg.gun0, seg.dgun)
    line = stretch_spheres(seg.entity, n, spheres, seg.t0, seg.t1, seg.c0, seg.c1, w0, w1)
    va, vb = np.triu_indices(n, 1)
    ones = np.ones(len(va))
    clear = clear_spans(line.spheres.take(va), line.t0[va], line.t1[va], line.c0[va], line.c1[va],
                        line.spheres.take(vb), line.t0[vb], line.t1[vb], line.c0[vb], line.c1[vb], w0 * ones, w1 * ones)
    # every span of every pair of segments of two vehicles within the window: the exact check
    i, j = np.meshgrid(np.arange(len(seg)), np.arange(len(seg)), indexing="ij")
    i, j = i.ravel(), j.ravel()
    keep = seg.entity[i] < seg.entity[j]
    i, j = i[keep], j[keep]
    u0 = np.maximum(np.maximum(seg.t0[i], seg.t0[j]), w0)
    u1 = np.minimum(np.minimum(seg.t1[i], seg.t1[j]), w1)
    both = u1 >= u0
    i, j, u0, u1 = i[both], j[both], u0[both], u1[both]
    idx = np.arange(len(i))
    ma, mb = _cut(seg.take(i), idx, u0, u1), _cut(seg.take(j), idx, u0, u1)
    touches = np.zeros(len(i), bool)
    touches[first_vehicle_contacts(body, ma, body, mb).span] = True
    touches[first_vehicle_contacts(body, _still(ma, idx), body, _still(mb, idx)).span] = True
    touching_pairs = set(zip(seg.entity[i][touches].tolist(), seg.entity[j][touches].tolist()))
    cleared = {(int(a), int(b)) for a, b in zip(va[clear], vb[clear])}
    assert not (cleared & touching_pairs), f"pairs cleared with a contact: {cleared & touching_pairs}"
    if reach == 6.0:
        assert touching_pairs
    if reach == 40.0:
        assert cleared


def test_a_vehicle_leaving_its_line_is_bounded_by_how_far_it_leaves_it():
    # a drives a V over [0, 2] s: (-10, 0) to (0, 8) to (10, 0); b stands at (0, 11), 3 m to a's side
    # at 1 s (hulls 3.46 m wide: they touch), 11 m from the line through a's ends
    from tankcd_cli.collision.pair_gate import stretch_spheres

    body = _body("t72")
    q = quaternion_from_euler(np.zeros(3), np.zeros(3), np.zeros(3))
    z = np.zeros(3)
    seg = Segments(np.array([0, 0, 1]), np.arange(3), np.array([0.0, 1.0, 0.0]), np.array([1.0, 2.0, 2.0]), q,
                   np.array([[-10.0, 0, 0], [0, 8, 0], [0, 11, 0]]), q, np.array([[0.0, 8, 0], [10, 0, 0], [0, 11, 0]]),
                   z, z, z, z, np.zeros(3, bool))
    clear, touches, _ = _verdicts(body, seg.take([0, 1]), body, seg.take([2, 2]))
    assert touches.any() and not (clear & touches).any()
    spheres = group_spheres(body, seg.q0, seg.c0, seg.q1, seg.turret0, seg.dturret, seg.gun0, seg.dgun)
    line = stretch_spheres(seg.entity, 2, spheres, seg.t0, seg.t1, seg.c0, seg.c1, 0.0, 2.0)
    both = clear_spans(line.spheres.take([0]), line.t0[:1], line.t1[:1], line.c0[:1], line.c1[:1],
                       line.spheres.take([1]), line.t0[1:], line.t1[1:], line.c0[1:], line.c1[1:], [0.0], [2.0])
    assert both.tolist() == [False]
