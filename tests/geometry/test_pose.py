"""Rotation conventions (REP 103, R = Rz(yaw) Ry(pitch) Rx(roll)) against scipy and closed forms."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tankcd_cli.geometry.pose import (
    attitude_from_slopes,
    euler_from_quaternion,
    quaternion_from_euler,
    rotation_matrix,
    wrap_angle,
)


def _random_angles(seed, n, pitch_limit=np.pi / 2 - 1e-3):
    rng = np.random.default_rng(seed)
    return (rng.uniform(-np.pi, np.pi, n), rng.uniform(-pitch_limit, pitch_limit, n), rng.uniform(-4 * np.pi, 4 * np.pi, n))


@settings(max_examples=60, deadline=None)
@given(st.floats(-np.pi / 2 + 0.01, np.pi / 2 - 0.01), st.floats(-1.5, 1.5), st.floats(-10, 10))
def test_property_rotations_quaternions_euler_agree(pitch, roll, yaw):
    R = rotation_matrix(np.array([roll]), np.array([pitch]), np.array([yaw]))[0]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    q = quaternion_from_euler(np.array([roll]), np.array([pitch]), np.array([yaw]))[0]
    assert q[0] >= 0 and np.linalg.norm(q) == pytest.approx(1.0)
    w, x, y, z = q
    Rq = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                   [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                   [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    np.testing.assert_allclose(Rq, R, atol=1e-12)
    r2, p2, y2 = euler_from_quaternion(q[None])
    assert r2[0] == pytest.approx(roll, abs=1e-9) and p2[0] == pytest.approx(pitch, abs=1e-9)
    assert np.cos(y2[0] - yaw) == pytest.approx(1.0)


def test_rotation_matrix_is_scipys_intrinsic_zyx():
    roll, pitch, yaw = _random_angles(0, 500)
    R = rotation_matrix(roll, pitch, yaw)
    expect = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll])).as_matrix()
    assert R.shape == (500, 3, 3)
    np.testing.assert_allclose(R, expect, atol=1e-12)
    # the product of the three elementary rotations, in that order
    Rz = Rotation.from_euler("z", yaw[:, None]).as_matrix()
    Ry = Rotation.from_euler("y", pitch[:, None]).as_matrix()
    Rx = Rotation.from_euler("x", roll[:, None]).as_matrix()
    np.testing.assert_allclose(R, Rz @ Ry @ Rx, atol=1e-12)


def test_rotation_matrix_keeps_the_leading_shape():
    assert rotation_matrix(0.1, 0.2, 0.3).shape == (3, 3)
    grid = rotation_matrix(np.zeros((4, 5)), np.zeros((4, 5)), np.zeros((4, 5)))
    assert grid.shape == (4, 5, 3, 3)
    np.testing.assert_array_equal(grid, np.broadcast_to(np.eye(3), (4, 5, 3, 3)))


def test_signs_are_rep103_x_forward_y_left_z_up():
    """Columns are the hull's axes in the world: yaw turns x towards y (counter-clockwise from
    above), negative pitch raises the nose, positive roll lowers the right side."""
    R = rotation_matrix(np.array([0.0]), np.array([0.0]), np.array([np.pi / 2]))[0]
    np.testing.assert_allclose(R[:, 0], [0, 1, 0], atol=1e-15)  # heading north: forward is +y
    np.testing.assert_allclose(R[:, 1], [-1, 0, 0], atol=1e-15)  # and left is west
    nose_up = rotation_matrix(np.array([0.0]), np.array([-0.2]), np.array([0.0]))[0]
    assert nose_up[2, 0] == pytest.approx(np.sin(0.2)) and nose_up[2, 0] > 0
    right_down = rotation_matrix(np.array([0.2]), np.array([0.0]), np.array([0.0]))[0]
    right = right_down @ [0.0, -1.0, 0.0]
    assert right[2] == pytest.approx(-np.sin(0.2)) and right[2] < 0


def test_quaternions_are_scipys_with_qw_never_negative():
    roll, pitch, yaw = _random_angles(1, 2000)
    q = quaternion_from_euler(roll, pitch, yaw)
    assert q.shape == (2000, 4)
    assert (q[:, 0] >= 0).all()
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    xyzw = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll])).as_quat()
    theirs = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    theirs = np.where(theirs[:, :1] < 0, -theirs, theirs)  # the same rotation, the same hemisphere
    np.testing.assert_allclose(q, theirs, atol=1e-12)


def test_a_half_turn_has_qw_zero_or_positive():
    q = quaternion_from_euler(np.array([0.0, 0.0, np.pi]), np.array([0.0, 0.0, 0.0]), np.array([np.pi, -np.pi, 0.0]))
    assert (q[:, 0] >= 0).all()
    np.testing.assert_allclose(np.abs(q), [[0, 0, 0, 1], [0, 0, 0, 1], [0, 1, 0, 0]], atol=1e-15)


def test_euler_from_any_unit_quaternion_is_scipys_and_either_sign():
    quat = Rotation.random(2000, random_state=2)
    xyzw = quat.as_quat()
    q = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    roll, pitch, yaw = euler_from_quaternion(q)
    yaw_s, pitch_s, roll_s = quat.as_euler("ZYX").T
    away = np.abs(pitch_s) < np.pi / 2 - 1e-3  # gimbal lock: the split of roll and yaw is arbitrary
    np.testing.assert_allclose(roll[away], roll_s[away], atol=1e-9)
    np.testing.assert_allclose(pitch, pitch_s, atol=1e-6)
    np.testing.assert_allclose(yaw[away], yaw_s[away], atol=1e-9)
    assert (yaw > -np.pi).all() and (yaw <= np.pi).all()
    # -q is the same rotation: the same angles
    for a, b in zip(euler_from_quaternion(-q), (roll, pitch, yaw)):
        np.testing.assert_allclose(np.cos(a - b), 1.0, atol=1e-12)
    # and the angles give the rotation back, up to the quaternion's sign
    back = quaternion_from_euler(roll, pitch, yaw)
    np.testing.assert_allclose(np.abs(np.sum(back * q, axis=1)), 1.0, atol=1e-9)
    np.testing.assert_allclose(rotation_matrix(roll, pitch, yaw), quat.as_matrix(), atol=1e-7)


def test_euler_round_trip_gives_the_angles_with_yaw_wrapped():
    roll, pitch, yaw = _random_angles(3, 2000, pitch_limit=np.pi / 2 - 1e-2)
    r, p, y = euler_from_quaternion(quaternion_from_euler(roll, pitch, yaw))
    np.testing.assert_allclose(r, roll, atol=1e-9)
    np.testing.assert_allclose(p, pitch, atol=1e-9)
    np.testing.assert_allclose(y, wrap_angle(yaw), atol=1e-9)


def test_euler_from_quaternion_takes_lists_and_clips_pitch():
    roll, pitch, yaw = euler_from_quaternion([[1.0, 0.0, 0.0, 0.0]])
    assert roll.tolist() == [0.0] and pitch.tolist() == [0.0] and yaw.tolist() == [0.0]
    # a quaternion a hair beyond unit at straight nose-down: pitch stays pi/2, not NaN
    s = np.sqrt(0.5) * (1 + 1e-12)
    _, pitch, _ = euler_from_quaternion(np.array([[s, 0.0, s, 0.0]]))
    assert pitch[0] == pytest.approx(np.pi / 2) and np.isfinite(pitch).all()


def test_wrap_angle_edges():
    pi = np.pi
    got = wrap_angle(np.array([pi, -pi, 3 * pi, -3 * pi, 0.0, -0.0, 2 * pi, -2 * pi, pi / 2, -pi / 2]))
    np.testing.assert_allclose(got, [pi, pi, pi, pi, 0.0, 0.0, 0.0, 0.0, pi / 2, -pi / 2], atol=1e-15)
    assert (got[:4] == pi).all()  # the half turn is +pi exactly, never -pi
    assert wrap_angle(np.nextafter(-pi, 0)) > -pi
    assert wrap_angle(0.5) == pytest.approx(0.5) and wrap_angle([7.0]).shape == (1,)
    assert np.isnan(wrap_angle(np.nan))


@given(st.floats(-1e6, 1e6))
def test_property_wrap_angle_lands_in_the_half_open_circle_on_the_same_direction(a):
    w = float(wrap_angle(a))
    assert -np.pi < w <= np.pi
    turns = (a - w) / (2 * np.pi)
    assert abs(turns - round(turns)) < 1e-9 * max(1.0, abs(a))


def test_attitude_from_slopes_closed_forms():
    b = np.array([0.0, 0.1, 0.0, -0.3, 0.2])
    c = np.array([0.0, 0.0, 0.1, 0.0, -0.4])
    roll, pitch = attitude_from_slopes(b, c)
    np.testing.assert_allclose(pitch, -np.arctan(b), atol=1e-15)
    np.testing.assert_allclose(roll[:4], np.arctan(c[:4]), atol=1e-15)  # b = 0 or c = 0: roll = atan c
    assert roll[4] == pytest.approx(np.arcsin(-0.4 / np.sqrt(1 + 0.04 + 0.16)))
    # uphill ahead: nose up (negative pitch); ground rising to the left: right side down (positive roll)
    assert pitch[1] < 0 and roll[2] > 0


@settings(max_examples=100, deadline=None)
@given(st.floats(-3, 3), st.floats(-3, 3), st.floats(-np.pi, np.pi))
def test_property_hull_lies_on_the_plane(b, c, yaw):
    """In the heading frame the hull's z axis is the plane's upward normal, and its x axis lies in
    the plane straight above the heading."""
    roll, pitch = attitude_from_slopes(np.array([b]), np.array([c]))
    R = rotation_matrix(roll, pitch, np.array([0.0]))[0]
    normal = np.array([-b, -c, 1.0]) / np.sqrt(1 + b * b + c * c)
    np.testing.assert_allclose(R[:, 2], normal, atol=1e-12)
    assert abs(R[:, 0] @ normal) < 1e-12 and abs(R[1, 0]) < 1e-12 and R[0, 0] > 0
    # the same in the world: the heading turns the frame and the plane alike
    Rw = rotation_matrix(roll, pitch, np.array([yaw]))[0]
    turn = rotation_matrix(np.array([0.0]), np.array([0.0]), np.array([yaw]))[0]
    np.testing.assert_allclose(Rw[:, 2], turn @ normal, atol=1e-12)
