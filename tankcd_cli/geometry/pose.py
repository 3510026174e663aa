"""Rotation conventions (docs/formats.md, Conventions): REP 103, R = Rz(yaw) Ry(pitch) Rx(roll).

x forward, y left, z up; nose-up pitch is negative, right-side-down roll is
positive. Radians here; degrees only in files and on the command line.
A support plane is written in the heading frame (u forward along the yaw
direction, v to the left, both horizontal): z = a + b u + c v.
"""

from __future__ import annotations

import numpy as np


def attitude_from_slopes(b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Roll and pitch (rad) of a hull lying on a plane of slopes b (forward) and c (left).

    The hull's x axis lies in the plane above the heading (pitch = -atan b) and
    its z axis is the plane's upward normal (sin roll = c / sqrt(1 + b^2 + c^2)).
    """
    pitch = -np.arctan(b)
    roll = np.arcsin(np.clip(c / np.sqrt(1.0 + b * b + c * c), -1.0, 1.0))
    return roll, pitch


def rotation_matrix(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), (N, 3, 3): columns are the hull's axes in the world."""
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    R = np.empty(np.shape(roll) + (3, 3))
    R[..., 0, 0] = cy * cp
    R[..., 0, 1] = cy * sp * sr - sy * cr
    R[..., 0, 2] = cy * sp * cr + sy * sr
    R[..., 1, 0] = sy * cp
    R[..., 1, 1] = sy * sp * sr + cy * cr
    R[..., 1, 2] = sy * sp * cr - cy * sr
    R[..., 2, 0] = -sp
    R[..., 2, 1] = cp * sr
    R[..., 2, 2] = cp * cr
    return R


def quaternion_from_euler(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Unit quaternion (N, 4) as (qw, qx, qy, qz) with qw >= 0, for R = Rz Ry Rx."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    q = np.stack([cr * cp * cy + sr * sp * sy,
                  sr * cp * cy - cr * sp * sy,
                  cr * sp * cy + sr * cp * sy,
                  cr * cp * sy - sr * sp * cy], axis=-1)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def euler_from_quaternion(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch, yaw (rad) of unit quaternions (N, 4) (qw, qx, qy, qz); yaw in (-pi, pi]."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angles into (-pi, pi]."""
    a = np.mod(np.asarray(angle, dtype=float) + np.pi, 2 * np.pi) - np.pi
    return np.where(a == -np.pi, np.pi, a)
