"""The motion between two rows of one vehicle (docs/formats.md, "Motion between rows"), in one place.

Between rows i and i+1 (``t`` rising from t_i to t_i+1) the footprint centre moves along the
straight segment at constant speed, and ``yaw``, ``turret`` and ``gun`` change at constant
rates along the shorter arc (a change of exactly 180 deg turns counter-clockwise). At a
fraction s of the interval (0 at row i, 1 at row i+1):

    x(s) = x_i + s (x_i+1 - x_i)        yaw(s) = yaw_i + s * arc(yaw_i, yaw_i+1)

and the same for y, turret and gun. Rows with the same ``t`` have no motion between them.

The ground sets z, roll and pitch along the way as it does at the rows: the matcher places
the hull at *sub-steps*, the fractions k / n (k = 0 .. n) with n the fewest steps such that no
step travels more than ``max_travel`` (half the post spacing; 0.25 m on meshes) or turns the
hull more than ``max_turn`` (1 deg). Between two sub-steps the hull moves rigidly: its origin
along the straight 3-D segment between the two placed origins, its attitude by the constant
angular velocity rotation (slerp) from one placed attitude to the other, while the turret and
gun keep their constant rates. That piecewise rigid, articulated motion is *the* motion every
continuous check of ``replay`` follows.

Motion bound: on a sub-step from attitude R_a to R_b (angle theta between them), origin
c_a to c_b, turret and gun changing by d_az and d_el, a point p of the vehicle moves, between
fractions u and w of the sub-step, at most

    |w - u| * (|c_b - c_a| + theta * rho + |d_az| * rho_az + |d_el| * rho_el)

where rho bounds the point's distance from the hull origin (under any articulation), rho_az its
distance from the turret axis and rho_el from the trunnion (0 for parts that do not turn with
them). Proof: p(s) = c(s) + R(s) A(s) p0, so |p(w) - p(u)| <= |c(w) - c(u)|
+ ||R(w) - R(u)|| |A(w) p0| + |A(w) p0 - A(u) p0|; the first term is linear in |w - u|; the
rotation R(u)^T R(w) is a turn by theta |w - u| about one axis, and a turn by phi moves no
point at distance r by more than 2 r sin(phi / 2) <= r phi; the articulation A turns the
turret by d_az |w - u| about its axis and the gun by d_el |w - u| about the trunnion, each
moving a point by at most its distance from that axis times the angle. Every term is a sum of
absolute values: two bodies closing head-on never cancel (each body's bound is added).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

MAX_TURN_DEG = 1.0
"""deg. The largest turn of the hull between two sub-steps of the ground (docs/formats.md#motion-between-rows)."""

MESH_TRAVEL = 0.25
"""m. The largest travel between two sub-steps on a mesh terrain (no post spacing to halve)."""


def shorter_arc_deg(a0, a1) -> np.ndarray:
    """The change (deg) from angle a0 to a1 along the shorter arc, in (-180, 180]: a change of
    exactly 180 deg (either way) turns counter-clockwise (+180)."""
    d = np.mod(np.asarray(a1, dtype=float) - np.asarray(a0, dtype=float) + 180.0, 360.0) - 180.0
    return np.where(d == -180.0, 180.0, d)


@dataclass(frozen=True)
class RowIntervals:
    """The intervals between consecutive rows of one vehicle, M of them (angles in degrees).

    first : (M,) the earlier row's index into the rows the intervals were made from
    t0, dt : (M,) start time and length, s
    x0, y0, dx, dy : (M,) start position and change, m
    yaw0, dyaw, turret0, dturret, gun0, dgun : (M,) start angles and their shorter-arc changes
    """

    first: np.ndarray
    t0: np.ndarray
    dt: np.ndarray
    x0: np.ndarray
    y0: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    yaw0: np.ndarray
    dyaw: np.ndarray
    turret0: np.ndarray
    dturret: np.ndarray
    gun0: np.ndarray
    dgun: np.ndarray

    def __len__(self) -> int:
        return len(self.t0)

    def take(self, idx) -> "RowIntervals":
        """The intervals ``idx`` (indices, a mask or a slice), in that order."""
        return RowIntervals(*(getattr(self, f.name)[idx] for f in fields(self)))

    @property
    def travel(self) -> np.ndarray:
        """(M,) horizontal travel of the footprint centre, m."""
        return np.hypot(self.dx, self.dy)

    def at(self, k: np.ndarray, s: np.ndarray) -> dict:
        """The state at fraction s of interval k (arrays broadcast): t, x, y, yaw_deg, turret_deg, gun_deg.

        Angles are returned unwrapped (start + s * change); wrap them where a range matters."""
        k = np.asarray(k)
        return {"t": self.t0[k] + s * self.dt[k], "x": self.x0[k] + s * self.dx[k], "y": self.y0[k] + s * self.dy[k],
                "yaw_deg": self.yaw0[k] + s * self.dyaw[k], "turret_deg": self.turret0[k] + s * self.dturret[k],
                "gun_deg": self.gun0[k] + s * self.dgun[k]}


def row_intervals(t, x, y, yaw_deg, turret_deg, gun_deg, first=None, links=None) -> RowIntervals:
    """The intervals between consecutive rows (N,) of one vehicle, skipping pairs with equal ``t``
    (no motion between them). ``first`` (N - 1,) names each pair's earlier row (default 0 .. N-2);
    ``links`` (N - 1,) bool, where given, keeps only the pairs it marks (rows of several vehicles in
    one table: a pair of two vehicles' rows, or one that starts a new piece of motion, is none)."""
    t, x, y = (np.asarray(a, dtype=float) for a in (t, x, y))
    yaw_deg, turret_deg, gun_deg = (np.asarray(a, dtype=float) for a in (yaw_deg, turret_deg, gun_deg))
    first = np.arange(max(len(t) - 1, 0)) if first is None else np.asarray(first)
    dt = np.diff(t)
    moving = dt > 0
    if links is not None:
        moving &= np.asarray(links, dtype=bool)
    keep = np.flatnonzero(moving)
    a, b = keep, keep + 1
    return RowIntervals(first[keep], t[a], dt[keep], x[a], y[a], x[b] - x[a], y[b] - y[a],
                        yaw_deg[a], shorter_arc_deg(yaw_deg[a], yaw_deg[b]),
                        turret_deg[a], shorter_arc_deg(turret_deg[a], turret_deg[b]),
                        gun_deg[a], gun_deg[b] - gun_deg[a])


def motion_at(t, x, y, yaw_deg, turret_deg, gun_deg, times) -> dict:
    """The state of the motion through rows (N,) of one vehicle at ``times`` (M,), s: a dict of
    (M,) arrays ``t``, ``x``, ``y``, ``yaw_deg``, ``turret_deg``, ``gun_deg`` (angles wrapped to
    [-180, 180), the gun's as it is), what rows logged at those times would hold.

    Between two rows the state is the motion's (``row_intervals``: straight, constant rates, the
    shorter arc); at a time shared by several rows, the last of them; before the first row or
    after the last, that row's state (the motion is not extended past its ends)."""
    t = np.asarray(t, dtype=float)
    times = np.asarray(times, dtype=float)
    cols = {"x": x, "y": y, "yaw_deg": yaw_deg, "turret_deg": turret_deg, "gun_deg": gun_deg}
    cols = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    if len(t) == 0:
        raise ValueError("the motion needs at least one row")
    k = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 1)  # the last row at or before
    out = {"t": times.copy()}
    out.update({name: v[k].copy() for name, v in cols.items()})
    inside = (times > t[0]) & (times < t[-1]) & (k < len(t) - 1)
    j = k[inside]
    dt = t[j + 1] - t[j]  # > 0: the last row at or before a time inside has a later time after it
    s = (times[inside] - t[j]) / dt
    for name, v in cols.items():
        if name in ("yaw_deg", "turret_deg"):
            change = shorter_arc_deg(v[j], v[j + 1])
        else:
            change = v[j + 1] - v[j]
        out[name][inside] = v[j] + s * change
    for name in ("yaw_deg", "turret_deg"):
        out[name] = np.mod(out[name] + 180.0, 360.0) - 180.0
    return out


def substep_counts(travel: np.ndarray, turn_deg: np.ndarray, max_travel: float,
                   max_turn_deg: float = MAX_TURN_DEG) -> np.ndarray:
    """(M,) the fewest equal sub-steps of each interval such that none travels more than
    ``max_travel`` m or turns the hull more than ``max_turn_deg``: at least 1 (the rows themselves)."""
    if not max_travel > 0:
        raise ValueError(f"max_travel must be positive, got {max_travel!r}")
    with np.errstate(invalid="ignore"):
        n = np.maximum(np.ceil(np.asarray(travel) / max_travel), np.ceil(np.abs(turn_deg) / max_turn_deg))
    n = np.where(np.isfinite(n), n, 1)
    return np.maximum(n, 1).astype(np.int64)


def substeps(intervals: RowIntervals, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The interior sub-steps of every interval: (interval index (S,), fraction (S,)), for
    k = 1 .. counts - 1 of each, in interval order then time order (the rows themselves, k = 0
    and k = counts, are not repeated)."""
    counts = np.asarray(counts, dtype=np.int64)
    inner = np.maximum(counts - 1, 0)
    owner = np.repeat(np.arange(len(counts)), inner)
    k = np.arange(inner.sum()) - np.repeat(np.cumsum(inner) - inner, inner) + 1
    return owner, k / counts[owner]


# --- rigid interpolation between two placed poses ------------------------------------------------

def quaternion_slerp(q0: np.ndarray, q1: np.ndarray, s) -> np.ndarray:
    """Unit quaternions (N, 4) (qw, qx, qy, qz) a fraction s (N,) of the constant-rate turn from q0
    to q1 (the shorter one: q1 taken with the sign nearer q0)."""
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    s = np.asarray(s, dtype=float)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot)
    angle = np.arccos(np.clip(dot, -1.0, 1.0))
    sin = np.sin(angle)
    small = sin < 1e-12
    with np.errstate(invalid="ignore", divide="ignore"):
        w0 = np.where(small, 1 - s, np.sin((1 - s) * angle) / np.where(small, 1, sin))
        w1 = np.where(small, s, np.sin(s * angle) / np.where(small, 1, sin))
    q = w0 * q0 + w1 * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def rotation_angle(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """(N,) the angle (rad) of the turn from attitude q0 to q1 (unit quaternions), in [0, pi]."""
    dot = np.abs(np.sum(np.asarray(q0, dtype=float) * np.asarray(q1, dtype=float), axis=-1))
    return 2 * np.arccos(np.clip(dot, 0.0, 1.0))


def quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices of unit quaternions (N, 4) (qw, qx, qy, qz)."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    R = np.empty(np.shape(w) + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 2, 1] = 2 * (y * z + w * x)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def axis_rotation(axis, angle) -> np.ndarray:
    """(N, 3, 3) turns by ``angle`` (N,) rad about unit ``axis`` (3,) (right hand: counter-clockwise seen
    from the axis' tip)."""
    u = np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a)[..., None, None], np.sin(a)[..., None, None]
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return c * np.eye(3) + s * K + (1 - c) * np.outer(u, u)
