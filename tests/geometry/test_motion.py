"""The motion between rows: shorter arcs, sub-steps, rigid interpolation and the motion bound."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from tankcd_cli.geometry.motion import (
    axis_rotation,
    motion_at,
    quaternion_matrix,
    quaternion_slerp,
    rotation_angle,
    row_intervals,
    shorter_arc_deg,
    substep_counts,
    substeps,
)
from tankcd_cli.geometry.pose import quaternion_from_euler, rotation_matrix
from tests.conftest import trajectory_columns


def test_shorter_arcs_wrap_and_a_half_turn_goes_counter_clockwise():
    assert shorter_arc_deg(170.0, -170.0) == pytest.approx(20.0)  # heading wrap: the short way
    assert shorter_arc_deg(-170.0, 170.0) == pytest.approx(-20.0)
    assert shorter_arc_deg(150.0, -150.0) == pytest.approx(60.0)  # the turret over the rear
    assert shorter_arc_deg(0.0, 180.0) == 180.0 and shorter_arc_deg(0.0, -180.0) == 180.0
    assert shorter_arc_deg(90.0, -90.0) == 180.0 and shorter_arc_deg(-90.0, 90.0) == 180.0
    assert shorter_arc_deg(10.0, 10.0 + 720.0) == 0.0
    assert shorter_arc_deg(359.0, 1.0) == pytest.approx(2.0)


@given(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4))
def test_the_arc_lands_on_the_target_and_is_the_shortest(a, b):
    d = shorter_arc_deg(a, b)
    assert -180.0 < d <= 180.0
    assert np.cos(np.radians(a + d - b)) == pytest.approx(1.0, abs=1e-9)


def test_intervals_skip_equal_times_and_carry_the_rows_they_start_at():
    t = [0.0, 1.0, 1.0, 3.0]
    iv = row_intervals(t, [0, 10, 10, 10], [0, 0, 5, 5], [170, -170, -170, 0], [0, 0, 0, 0], [0, 0, 0, 5])
    assert iv.first.tolist() == [0, 2]  # rows 1 and 2 share t = 1: no motion between them
    assert iv.dt.tolist() == [1.0, 2.0]
    assert iv.dyaw.tolist() == pytest.approx([20.0, 170.0])
    at = iv.at(np.array([0, 1]), np.array([0.5, 0.5]))
    assert at["t"].tolist() == [0.5, 2.0] and at["x"].tolist() == [5.0, 10.0]
    assert at["yaw_deg"].tolist() == pytest.approx([180.0, -85.0])
    assert iv.travel.tolist() == [10.0, 0.0]


def test_substeps_bound_travel_and_turn():
    n = substep_counts(np.array([0.0, 1.0, 1.01, 0.1, 3.0]), np.array([0.0, 0.0, 0.0, 2.5, 0.5]), max_travel=0.5)
    assert n.tolist() == [1, 2, 3, 3, 6]
    owner, frac = substeps(None, n)
    assert owner.tolist() == [1, 2, 2, 3, 3, 4, 4, 4, 4, 4]
    assert frac[:3].tolist() == pytest.approx([0.5, 1 / 3, 2 / 3])
    with pytest.raises(ValueError):
        substep_counts(np.ones(1), np.ones(1), max_travel=0.0)


def test_slerp_is_scipys_and_turns_at_a_constant_rate():
    rng = np.random.default_rng(0)
    a, b = Rotation.random(50, random_state=1), Rotation.random(50, random_state=2)
    qa = a.as_quat(scalar_first=True)
    qb = b.as_quat(scalar_first=True)
    s = rng.uniform(0, 1, 50)
    got = quaternion_matrix(quaternion_slerp(qa, qb, s))
    for i in range(50):
        want = Slerp([0, 1], Rotation.concatenate([a[i], b[i]]))([s[i]]).as_matrix()[0]
        np.testing.assert_allclose(got[i], want, atol=1e-12)
    # a constant rate: the angle from the start grows linearly
    total = rotation_angle(qa, qb)
    part = rotation_angle(qa, quaternion_slerp(qa, qb, s))
    np.testing.assert_allclose(part, s * total, atol=1e-9)
    # the matrix of a quaternion is the REP 103 rotation of its angles
    roll, pitch, yaw = rng.uniform(-1, 1, (3, 20))
    np.testing.assert_allclose(quaternion_matrix(quaternion_from_euler(roll, pitch, yaw)),
                               rotation_matrix(roll, pitch, yaw), atol=1e-12)
    np.testing.assert_allclose(axis_rotation([0, 0, 1], np.radians([90.0]))[0] @ [1, 0, 0], [0, 1, 0], atol=1e-15)


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 10_000))
def test_the_motion_bound_holds_for_every_point_and_fraction(seed):
    # |p(w) - p(u)| <= |w - u| (|dc| + theta rho) for any point at distance <= rho from the origin
    rng = np.random.default_rng(seed)
    q0, q1 = Rotation.random(2, random_state=seed).as_quat(scalar_first=True)
    c0, c1 = rng.uniform(-5, 5, (2, 3))
    p = rng.normal(size=(30, 3)) * rng.uniform(0.1, 6)
    rho = np.linalg.norm(p, axis=1).max()
    theta = rotation_angle(q0, q1)
    u, w = np.sort(rng.uniform(0, 1, 2))

    def at(s):
        R = quaternion_matrix(quaternion_slerp(q0[None], q1[None], np.array([s])))[0]
        return p @ R.T + c0 + s * (c1 - c0)

    moved = np.linalg.norm(at(w) - at(u), axis=1).max()
    assert moved <= (w - u) * (np.linalg.norm(c1 - c0) + theta * rho) + 1e-9

def test_the_motion_at_the_rows_is_the_rows_and_between_them_the_intervals():
    c = trajectory_columns([0.0, 1.0, 3.0, 4.0], [0.0, 10.0, 10.0, 4.0], [0.0, 0.0, 6.0, 6.0], [10.0, 170.0, -170.0, -90.0],
                 [0.0, 90.0, 180.0, 181.0], [0.0, 5.0, -5.0, 0.0])
    at = motion_at(c["t"], c["x"], c["y"], c["yaw_deg"], c["turret_deg"], c["gun_deg"], c["t"])
    for name in ("x", "y", "gun_deg"):
        np.testing.assert_array_equal(at[name], c[name])
    np.testing.assert_allclose(at["yaw_deg"], [10.0, 170.0, -170.0, -90.0])
    np.testing.assert_allclose(at["turret_deg"], [0.0, 90.0, -180.0, -179.0])
    # between the rows: what the intervals (the checks' own motion) give at the same fraction
    iv = row_intervals(c["t"], c["x"], c["y"], c["yaw_deg"], c["turret_deg"], c["gun_deg"])
    k, s = np.array([0, 1, 1, 2]), np.array([0.25, 0.5, 0.75, 0.1])
    want = iv.at(k, s)
    got = motion_at(c["t"], c["x"], c["y"], c["yaw_deg"], c["turret_deg"], c["gun_deg"], want["t"])
    for name in ("x", "y", "gun_deg"):
        np.testing.assert_allclose(got[name], want[name])
    for name in ("yaw_deg", "turret_deg"):
        np.testing.assert_allclose(np.mod(got[name] - want[name] + 180, 360) - 180, 0.0, atol=1e-9)
    # 170 -> -170 takes the short way, through 180: half way is a heading of +-180
    assert abs(abs(got["yaw_deg"][1]) - 180.0) < 1e-9


def test_the_motion_holds_still_at_its_ends_and_takes_the_last_of_rows_at_one_time():
    c = trajectory_columns([0.0, 1.0, 1.0, 2.0], [0.0, 1.0, 5.0, 7.0], [0.0] * 4, [0.0] * 4)
    at = motion_at(c["t"], c["x"], c["y"], c["yaw_deg"], c["turret_deg"], c["gun_deg"], [-1.0, 0.5, 1.0, 1.5, 9.0])
    np.testing.assert_allclose(at["x"], [0.0, 0.5, 5.0, 6.0, 7.0])
