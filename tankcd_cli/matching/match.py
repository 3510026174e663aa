"""Place the vehicle on the terrain at many poses at once: ``match``.

Every matcher yields a support plane in the heading frame (u forward along
the yaw direction, v to the left, both horizontal, origin at the footprint
centre): z = a + b u + c v. The hull lies on that plane: the vehicle-frame
origin sits at (x, y, a), its x axis in the plane above the heading, its z
axis along the plane's upward normal.

Matchers (``MATCHERS``):

``two_point``  the paper's TPTMA: heights at the front and rear midpoints of
               the footprint give the pitch and, at their midpoint, the height;
               the roll comes from the terrain normal under the footprint centre.
``four_point`` the paper's FPTMA: the four footprint corners. Where they are not
               coplanar, one diagonal pair is high and the hull rocks on it; the
               paper rests on the high pair and one of the two others (the
               "floating point" is the other). Choosing one would jump from side
               to side as the ground changes, so the hull rests on the high
               pair with the two low corners floating equally (the least-squares
               plane of the corners raised onto the high pair): continuous.
``six_point``  the paper's SPTMA: front, middle and rear of each track. The three
               supporting points are those whose plane has no point above it and
               the footprint centre over their triangle: the facet of the
               points' upper convex hull above the centre.
``wheel_stations`` the same support rule over the ground at every road-wheel station of
               each track (``vehicle.road_wheels`` a side), sampled at both edges of the
               track (4 x road_wheels samples): a track on a crest or a ditch's lip bears
               where the ground is, which six points on the centre lines miss.
``reference``  the ground truth (docs/formats.md, Conventions): the lowest plane over the footprint
               centre that no ground point of either track's contact patch rises
               above, from the exact ground under the patches (every terrain
               triangle clipped to them), the patches re-projected for the
               hull's tilt and solved again until the tilt settles.
``auto``       the matcher the worst region class under the footprint calls for
               (``AUTO_RULE``, from measurement: the corpus of ``tradeoff.corpus``
               finds wheel_stations the most accurate on general and uneven ground,
               and, with every matcher's median error 0 on flat ground, the one the
               fewest poses fail the certificate with there too; the paper's rule,
               two, four and six points, is less accurate in every class).

With ``escalate`` (the default for ``auto``), every key-point pose is then
checked against the reference's certificate (``certify``) and those that fail
it are solved by the reference (matcher ``wheel_stations+reference`` and so
on): every pose within the tolerance of the reference.

Key points are projected vertically from their untilted positions, as the
paper does. Where a key point is off the terrain, the pose comes from the
reference over the part of the footprint that is on the terrain (status
``partly_off``); where that cannot carry the hull, the pose is NaN with status
``off``.

Measures of how far each pose is from physical (``measure=True``):
``penetration`` the highest ground point of the contact patches above the
hull's plane (0 if none); ``gap`` the largest height of the plane above the
ground at the six key points (front, middle, rear of each track's centre line).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from tankcd_cli.geometry.pose import (
    attitude_from_slopes,
    quaternion_from_euler,
    rotation_matrix,
    wrap_angle,
)
from tankcd_cli.gates import GateTally
from tankcd_cli.geometry.support_plane import support_planes_fixed
from tankcd_cli.names import (  # noqa: F401 (shared names)
    AUTO_RULE,
    CLASS_NAMES,
    ESCALATED,
    KEY_POINT_MATCHERS,
    MATCHER_CHOICES,
    MATCHERS,
    NO_CLASS,
    OFF,
    OK,
    PARTLY_OFF,
    PLACED_BY,
    REFERENCE,
    STATUS,
)
from tankcd_cli.tolerances import ATTITUDE_TOLERANCE_DEG, EPS_XY, ESCALATION_ATTITUDE_DEG
from tankcd_cli.vehicle import Vehicle, key_points, wheel_stations


@dataclass
class Poses:
    """Matched poses, N of each (angles in radians).

    position : (N, 3) world position of the vehicle-frame origin, m
    roll, pitch, yaw : (N,) rad (REP 103)
    quaternion : (N, 4) (qw, qx, qy, qz), qw >= 0
    plane : (N, 3) support plane (a, b, c) in the heading frame
    region : (N,) uint8 worst class under the footprint (255 unknown)
    matcher : (N,) int index into PLACED_BY
    status : (N,) int index into STATUS
    penetration, gap : (N,) m (NaN when not measured)
    covered : (N,) share of the contact patches over terrain (NaN when not measured)
    """

    position: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    quaternion: np.ndarray
    plane: np.ndarray
    region: np.ndarray
    matcher: np.ndarray
    status: np.ndarray
    penetration: np.ndarray
    gap: np.ndarray
    covered: np.ndarray

    @property
    def rotation(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices, R = Rz(yaw) Ry(pitch) Rx(roll)."""
        return rotation_matrix(self.roll, self.pitch, self.yaw)

    def __len__(self) -> int:
        return len(self.yaw)


def escalation_tolerance(vehicle: Vehicle, attitude_deg: float = ESCALATION_ATTITUDE_DEG) -> float:
    """The height tolerance (m) of the certificate at the footprint's corners: the difference a
    plane may have there from the reference's and still be within ``attitude_deg`` of its
    attitude about either axis (half the footprint's width is the shorter lever)."""
    lever = min(vehicle.track_length, vehicle.footprint_width) / 2
    return lever * float(np.tan(np.radians(attitude_deg)))


def match(surface, vehicle: Vehicle, x, y, yaw, matcher: str = "auto", measure: bool = True,
          tilt_iterations: int = 30, regions: bool = True, escalate: bool | None = None,
          tolerance: float | None = None, attitude_tolerance: float | None = None,
          gates: GateTally | None = None) -> Poses:
    """Place ``vehicle`` at footprint centres (x, y) m with headings ``yaw`` rad.

    surface : a :class:`~tankcd_cli.terrain.surface.Surface` (either layout's)
    matcher : one of ``MATCHER_CHOICES``
    measure : also compute penetration, gap and coverage (costs an exact footprint pass)
    regions : report the worst region class under each footprint (always done for ``auto``)
    escalate : check the key-point poses against the reference's certificate and solve those
        that fail it by the reference (None, the default: for ``auto`` only, whose error it bounds)
    tolerance : the certificate's height tolerance, m (default ``escalation_tolerance``)
    attitude_tolerance : the certificate's attitude tolerance, deg (default
        ``tolerances.ATTITUDE_TOLERANCE_DEG``)
    gates : where given and enabled, the certificate's verdict is proven from bounds where they
        suffice (``certificate_gate``: the same verdict, no exact pass) and counted there
    """
    if matcher not in MATCHER_CHOICES:
        raise ValueError(f"unknown matcher {matcher!r}; choose one of {', '.join(MATCHER_CHOICES)}")
    x = np.atleast_1d(np.asarray(x, dtype=float))
    y = np.atleast_1d(np.asarray(y, dtype=float))
    yaw = wrap_angle(np.atleast_1d(np.asarray(yaw, dtype=float)))
    n = len(x)
    region = np.full(n, NO_CLASS, dtype=np.uint8)
    if regions or matcher == "auto":
        region = surface.region_under(x, y, yaw, vehicle.track_length, vehicle.footprint_width)
    if matcher == "auto":
        rule = np.array([MATCHERS.index(AUTO_RULE[name]) for name in CLASS_NAMES], dtype=np.int64)
        choice = np.where(region <= 2, rule[np.minimum(region, 2)], REFERENCE).astype(np.int64)
    else:
        choice = np.full(n, MATCHERS.index(matcher), dtype=np.int64)

    plane = np.full((n, 3), np.nan)
    status = np.full(n, OK, dtype=np.int64)
    for code, solver in enumerate((_two_point, _four_point, _six_point, _wheel_stations)):
        idx = np.flatnonzero(choice == code)
        if len(idx):
            plane[idx], ok = solver(surface, vehicle, x[idx], y[idx], yaw[idx])
            fallback = idx[~ok]
            choice[fallback] = REFERENCE
            status[fallback] = PARTLY_OFF
    penetration = np.full(n, np.nan)
    covered = np.full(n, np.nan)
    measured = np.zeros(n, dtype=bool)  # penetration and coverage already known from the certificate's pass
    if escalate or (escalate is None and matcher == "auto"):
        # the reference starts level for these too (a start nearer the answer can settle on
        # another fixed point where the ground offers several: not the reference's pose)
        kp = np.flatnonzero(choice < REFERENCE)
        tol = escalation_tolerance(vehicle) if tolerance is None else float(tolerance)
        cert = certify(surface, vehicle, x[kp], y[kp], yaw[kp], plane[kp], tol,
                       ATTITUDE_TOLERANCE_DEG if attitude_tolerance is None else float(attitude_tolerance),
                       gates=gates, measure=measure)
        choice[kp[~cert.passed]] += ESCALATED
        if measure:
            passed = kp[cert.passed]
            penetration[passed], covered[passed] = cert.penetration[cert.passed], cert.covered[cert.passed]
            measured[passed] = True
    idx = np.flatnonzero(choice >= REFERENCE)
    if len(idx):
        plane[idx], st, covered_ref = reference_planes(surface, vehicle, x[idx], y[idx], yaw[idx], tilt_iterations)
        status[idx] = np.maximum(status[idx], np.where(covered_ref < 1 - 1e-9, PARTLY_OFF, OK))
        status[idx[st != 0]] = OFF
    plane[status == OFF] = np.nan

    roll, pitch = attitude_from_slopes(plane[:, 1], plane[:, 2])
    position = np.column_stack([x, y, plane[:, 0]])
    quat = quaternion_from_euler(roll, pitch, yaw)
    gap = np.full(n, np.nan)
    if measure:
        good = np.flatnonzero((status != OFF) & ~measured)
        if len(good):
            penetration[good], covered[good] = footprint_penetration(surface, vehicle, x[good], y[good], yaw[good],
                                                                     plane[good], roll[good], pitch[good])
        good = np.flatnonzero(status != OFF)
        if len(good):
            gap[good] = wheel_gap(surface, vehicle, x[good], y[good], yaw[good], plane[good])
    return Poses(position, roll, pitch, yaw, quat, plane, region, choice, status, penetration, gap, covered)


class Certificate(NamedTuple):
    """The certificate's verdict on N planes, and what its passes measured on the way (N,) each."""

    passed: np.ndarray  # bool
    penetration: np.ndarray  # m: the highest ground under the patches above the plane (>= 0; NaN: not checked)
    covered: np.ndarray  # the share of the contact patches over terrain (NaN: not checked)


def certify(surface, vehicle: Vehicle, x, y, yaw, planes: np.ndarray, tolerance: float,
            attitude_tolerance: float = ATTITUDE_TOLERANCE_DEG, gates: GateTally | None = None,
            measure: bool = True) -> Certificate:
    """Whether each plane (N, 3) passes the reference's certificate within ``tolerance`` m and
    ``attitude_tolerance`` deg.

    The reference pose is the lowest plane that no ground under the tracks' contact patches
    rises above, with the patches projected for that plane's own tilt, found by starting from
    the untilted patches. A plane passes when both of these hold within ``tolerance`` at every
    corner of the footprint (the largest difference of the two planes' heights there):

    - it is the lowest plane under the patches projected for its own tilt: then no ground
      rises more than that above it (it does not cut the ground), and it rests on ground that
      surrounds the centre (it does not float or tip): a pose the rigid hull can rest in.
      This plane is also within ``attitude_tolerance`` of it in tilt (the angle between their
      normals): the height alone lets a plane roll by up to ``tolerance`` over half the
      footprint's width, 1 degree at the default;
    - it is the lowest plane under the untilted patches too (the reference's first round), so
      the reference's iteration starts where it is and stays: where the ground offers the hull
      two poses (balanced across a crest, it rests tipped either way), the plane is the one
      the reference takes, not the other. Only the height is held here: this round tells two
      resting poses apart, degrees apart; its plane, for patches the pose does not have, is
      not the reference's answer (on a berm the reference's own plane is more than 0.5 degrees
      from it).

    Each is one exact footprint pass, both searching from the given plane's slopes. The
    untilted pass comes first; the pass at the plane's own tilt is made only for the planes
    that pass it, and it also gives their penetration and covered share as
    ``footprint_penetration`` measures them (the same patches, the same ground), so a pose that
    passes needs no third. A plane the passes cannot check (not finite, no support found) fails.
    """
    n = len(x)
    attitude = np.radians(attitude_tolerance)
    ok = np.zeros(n, dtype=bool)
    penetration = np.full(n, np.nan)
    covered = np.full(n, np.nan)
    if gates is not None and gates.enabled and n:
        proven = certificate_gate(surface, vehicle, x, y, yaw, planes, tolerance, attitude)
        gates.add("certificate", n, int(proven.sum()))
        if proven.any():
            ok[proven] = True
            if measure:  # the pass at the plane's own tilt, measuring only: the same points, the same bits
                p = planes[proven]
                roll, pitch = attitude_from_slopes(p[:, 1], p[:, 2])
                high, covered[proven], _ = surface.highest_over_patches(
                    x[proven], y[proven], yaw[proven], patch_quads(vehicle, roll, pitch), p)
                penetration[proven] = np.maximum(high, 0.0)
            rest = np.flatnonzero(~proven)
            if len(rest):
                cert = certify(surface, vehicle, x[rest], y[rest], yaw[rest], planes[rest], tolerance,
                               attitude_tolerance)
                ok[rest], penetration[rest], covered[rest] = cert
            return Certificate(ok, penetration, covered)
    level = surface.support_plane_under(x, y, yaw, patch_quads(vehicle, np.zeros(n), np.zeros(n)), start=planes)
    with np.errstate(invalid="ignore"):
        near = np.flatnonzero((level[2] == 0) & (corner_gap(vehicle, planes, level[0]) <= tolerance))
    if len(near) == 0:
        return Certificate(ok, penetration, covered)
    p = planes[near]
    roll, pitch = attitude_from_slopes(p[:, 1], p[:, 2])
    lowest, high, covered[near], status = surface.support_and_highest(
        x[near], y[near], yaw[near], patch_quads(vehicle, roll, pitch), p)
    penetration[near] = np.maximum(high, 0.0)
    with np.errstate(invalid="ignore"):
        ok[near] = (status == 0) & (corner_gap(vehicle, p, lowest) <= tolerance) & (plane_angle(p, lowest) <= attitude)
    return Certificate(ok, penetration, covered)


GATE_MARGIN = 1e-6  # m, and rad: the gate's bounds clear the certificate's limits by this, far above rounding


def certificate_gate(surface, vehicle: Vehicle, x, y, yaw, planes: np.ndarray, tolerance: float,
                     attitude: float) -> np.ndarray:
    """(N,) bool: the planes (N, 3) that provably pass ``certify`` (``tolerance`` m, ``attitude``
    rad), from the ground's slab about each plane alone (``surface.plane_slab``: lo <= ground -
    plane <= hi over a box holding both passes' patches, all of it on valid posts); no exact pass.

    Proof. Let S be either pass's support plane and d = S - p, linear in (u, v). S lies on or
    above the ground at every point of its patches P, so d >= lo there. S is the lowest plane
    over the centre: its height there is a convex combination of the ground's at its support
    points, so d(0) <= hi. P is symmetric about the centre (the two tracks; the tilt's projection
    is linear), so for q in P, d(q) = 2 d(0) - d(-q) <= 2 hi - lo: |d| <= B = max(|lo|, |2 hi - lo|)
    over P, in particular at the images M X of the patches' outer corners X = (+-L/2, +-W/2)
    (L the track length, W the footprint width; M the projection for the tilt, the identity for
    the untilted pass). A footprint corner c, where ``corner_gap`` measures, is M w for
    w = M^-1 c; bilinear weights over the four X reproduce a linear function exactly and sum in
    absolute value to K = max(1, 2|w_u|/L) max(1, 2|w_v|/W), so |d(c)| <= K B. The slopes:
    d(M X+,+) - d(M X-,+) = db cos(pitch) L and d(M X+,+) - d(M X+,-) = (db sin(pitch) sin(roll)
    + dc cos(roll)) W bound |db| and |dc|, and the angle between the normals (-b, -c, 1) is at
    most |(db, dc)| (the map from slopes to unit normals is 1-Lipschitz). Where K B is within
    ``tolerance`` for both passes and the slope bound within ``attitude`` (by ``GATE_MARGIN``),
    both passes find a support (the box is wholly on full cells, so the patches are over
    terrain and surround the centre) and pass: the verdict ``certify`` would give. Only that
    verdict is skipped; what it measures on the way is measured by the caller."""
    n = len(x)
    proven = np.zeros(n, dtype=bool)
    planes = np.asarray(planes, dtype=float)
    finite = np.flatnonzero(np.isfinite(planes).all(axis=1))
    if len(finite) == 0:
        return proven
    p = planes[finite]
    roll, pitch = attitude_from_slopes(p[:, 1], p[:, 2])
    L, W = vehicle.track_length, vehicle.footprint_width
    # every corner of either pass's patches, (xi cp + eta sp sr, eta cr) for |xi| <= L/2, |eta| <= W/2,
    # lies in |u| <= R, |v| <= W/2 (R the footprint's half-diagonal, by Cauchy-Schwarz): one box for all
    R = float(np.hypot(L, W)) / 2
    box = np.array([[[-R, -W / 2], [R, -W / 2], [R, W / 2], [-R, W / 2]]])
    # B >= hi - lo, and B must be within the tolerance: a wider slab proves nothing (the pass stops early)
    lo, hi = surface.plane_slab(x[finite], y[finite], yaw[finite], box, p, limit=tolerance)
    with np.errstate(invalid="ignore"):
        bound = np.maximum(np.abs(lo), np.abs(2 * hi - lo))
        cp, sp, cr, sr = np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
        wv = (W / 2) / cr
        wu = (L / 2 + np.abs(sp * sr) * wv) / cp
        K = np.maximum(1.0, 2 * wu / L) * np.maximum(1.0, 2 * wv / W)
        db = 2 * bound / (cp * L)
        dc = (2 * bound / W + db * np.abs(sp * sr)) / cr
        passes = ((bound <= tolerance - GATE_MARGIN) & (K * bound <= tolerance - GATE_MARGIN)
                  & (np.hypot(db, dc) <= attitude - GATE_MARGIN))
    proven[finite] = passes
    return proven


def corner_gap(vehicle: Vehicle, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The largest difference (m) of two planes' (N, 3) heights at the footprint's corners (NaN
    where either is not finite)."""
    d = p - q
    return np.abs(d[:, 0]) + vehicle.track_length / 2 * np.abs(d[:, 1]) + vehicle.footprint_width / 2 * np.abs(d[:, 2])


def plane_angle(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(N,) the angle (rad) between two planes' (N, 3) normals, (-b, -c, 1) for z = a + b u + c v
    (NaN where either is not finite); atan2 of the cross and dot products, exact near 0."""
    n = np.stack([-p[:, 1], -p[:, 2], np.ones(len(p))], axis=1)
    m = np.stack([-q[:, 1], -q[:, 2], np.ones(len(q))], axis=1)
    return np.arctan2(np.linalg.norm(np.cross(n, m), axis=1), np.einsum("ij,ij->i", n, m))


def certified(surface, vehicle: Vehicle, x, y, yaw, planes: np.ndarray, tolerance: float,
              attitude_tolerance: float = ATTITUDE_TOLERANCE_DEG) -> np.ndarray:
    """Whether each plane (N, 3) passes the reference's certificate within ``tolerance`` m and
    ``attitude_tolerance`` deg (N,) bool (``certify``'s verdict alone)."""
    return certify(surface, vehicle, x, y, yaw, planes, tolerance, attitude_tolerance).passed


# --- key points -----------------------------------------------------------------

def _heights(surface, x, y, yaw, points):
    """Ground heights (N, k) under key points (k, 2) given in the heading frame, and whether all
    of a pose's points are on the terrain (N,)."""
    z = surface.heights_at(x, y, yaw, points)
    return z, np.isfinite(z).all(axis=1)


def _two_point(surface, vehicle, x, y, yaw):
    z, ok = _heights(surface, x, y, yaw, key_points(vehicle, 2))  # front, rear
    zc, gx, gy = surface.height_slope(x, y)  # the centre, for the normal
    ok &= np.isfinite(zc)
    half = vehicle.track_length / 2
    b = (z[:, 0] - z[:, 1]) / (2 * half)
    a = 0.5 * (z[:, 0] + z[:, 1])
    # the terrain's slope to the left under the centre (its normal, turned into the heading frame)
    c = -np.sin(yaw) * gx + np.cos(yaw) * gy
    return np.column_stack([a, b, c]), ok


def _four_point(surface, vehicle, x, y, yaw):
    pts = key_points(vehicle, 4)  # a (front left), b (front right), c (rear right), d (rear left)
    z, ok = _heights(surface, x, y, yaw, pts)
    h, g = vehicle.track_length / 2, vehicle.track_gauge / 2
    za, zb, zc, zd = z.T
    mean = z.mean(axis=1)
    slope_u = ((za + zb) - (zc + zd)) / (4 * h)
    slope_v = ((za + zd) - (zb + zc)) / (4 * g)
    twist = za + zc - zb - zd  # > 0: a and c are the high diagonal; < 0: b and d
    return np.column_stack([mean + np.abs(twist) / 4, slope_u, slope_v]), ok


def _six_point(surface, vehicle, x, y, yaw):
    return _supported(surface, x, y, yaw, key_points(vehicle, 6))


def _wheel_stations(surface, vehicle, x, y, yaw):
    return _supported(surface, x, y, yaw, wheel_stations(vehicle))


def _supported(surface, x, y, yaw, pts):
    """The support plane of ground samples at ``pts`` (k, 2) in the heading frame: the facet of
    their upper convex hull above the footprint centre."""
    z, ok = _heights(surface, x, y, yaw, pts)
    planes = np.full((len(x), 3), np.nan)
    if ok.any():
        planes[ok], st = support_planes_fixed(pts[:, 0].copy(), pts[:, 1].copy(), np.ascontiguousarray(z[ok]), EPS_XY)
        bad = np.flatnonzero(ok)[st != 0]
        ok[bad] = False
    return planes, ok


# --- the exact footprint ----------------------------------------------------------

def patch_quads(vehicle: Vehicle, roll: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """The two contact patches projected to the heading frame, (N, 2, 4, 2), counter-clockwise.

    A vehicle-frame point (xi, eta) of the hull's ground plane lies, seen from
    above, at (xi cos(pitch) + eta sin(pitch) sin(roll), eta cos(roll)).
    """
    h, g, w = vehicle.track_length / 2, vehicle.track_gauge / 2, vehicle.track_width / 2
    base = np.array([[[-h, g - w], [h, g - w], [h, g + w], [-h, g + w]],
                     [[-h, -g - w], [h, -g - w], [h, -g + w], [-h, -g + w]]])
    cp, sp = np.cos(pitch)[:, None, None], np.sin(pitch)[:, None, None]
    cr, sr = np.cos(roll)[:, None, None], np.sin(roll)[:, None, None]
    xi, eta = base[None, :, :, 0], base[None, :, :, 1]
    return np.stack([xi * cp + eta * sp * sr, eta * cr], axis=-1)


def reference_planes(surface, vehicle, x, y, yaw, tilt_iterations: int = 30, tilt_tolerance: float = 1e-10):
    """The rigid-hull reference: planes (N, 3), status (N,) (0 ok), covered share (N,).

    The contact patches seen from above depend on the hull's tilt, which the
    plane decides: a fixed point. Solve, re-project the patches for the new
    tilt, solve again, until the tilt moves less than ``tilt_tolerance`` rad.
    Plain iteration settles in a few rounds on ordinary ground but oscillates
    slowly where the tilt changes which ground carries the hull (a ditch as
    long as the tracks): each pose's step is extrapolated by the ratio of its
    last two steps (Aitken), which settles those in about 15 rounds.

    Where no fixed point exists (a balanced see-saw: each tilt puts the hull
    on ground that calls for the other), the last two planes are compared
    under their own tilts and the less penetrating one is raised until it
    penetrates nothing: a hull that floats by millimetres rather than sinks.
    """
    n = len(x)
    tilt = np.zeros((n, 2))  # roll, pitch
    previous_step = np.zeros((n, 2))
    planes = np.full((n, 3), np.nan)
    earlier = np.full((n, 3), np.nan)  # the plane of the round before, for poses that never settle
    covered = np.zeros(n)
    status = np.ones(n, dtype=np.int64)
    active = np.arange(n)
    for round_ in range(max(1, tilt_iterations)):
        quads = patch_quads(vehicle, tilt[active, 0], tilt[active, 1])
        # after the first round, the search starts from the last plane (the answer moves little)
        pl, cov, st = surface.support_plane_under(x[active], y[active], yaw[active], quads,
                                                  start=planes[active] if round_ else None)
        good = st == 0
        if round_ == 0:
            planes[active], covered[active], status[active] = pl, cov, st
        else:
            # a later round that finds no support (an extrapolated tilt too steep) keeps the last plane
            keep = active[good]
            earlier[keep] = planes[keep]
            planes[keep], covered[keep] = pl[good], cov[good]
        step = np.column_stack(attitude_from_slopes(pl[:, 1], pl[:, 2])) - tilt[active]
        step[~good] = 0.0
        moving = good & (np.abs(step).max(axis=1) > tilt_tolerance)
        prev = previous_step[active]
        denom = np.einsum("ij,ij->i", prev, prev)
        with np.errstate(invalid="ignore", divide="ignore"):
            rho = np.where(denom > 0, np.einsum("ij,ij->i", step, prev) / denom, 0.0)
        gain = np.where((rho < 0.95) & (round_ > 0), np.clip(1.0 / (1.0 - rho), 0.2, 5.0), 1.0)
        tilt[active] = np.clip(tilt[active] + gain[:, None] * step, -1.4, 1.4)
        previous_step[active] = step
        active = active[moving]
        if len(active) == 0:
            break
    if len(active):
        # no fixed point: the hull is balanced where a change of tilt changes the ground that
        # carries it (a see-saw). Of the last two planes keep the one that penetrates least
        # under its own tilt, raised until it does not penetrate at all.
        best = planes[active].copy()
        best_depth = np.full(len(active), np.inf)
        for candidate in (planes[active], earlier[active]):
            ok = np.isfinite(candidate).all(axis=1)
            depth = np.full(len(active), np.inf)
            if ok.any():
                roll, pitch = attitude_from_slopes(candidate[ok, 1], candidate[ok, 2])
                d, _ = footprint_penetration(surface, vehicle, x[active[ok]], y[active[ok]], yaw[active[ok]],
                                             candidate[ok], roll, pitch)
                depth[ok] = np.where(np.isfinite(d), d, np.inf)
            better = depth < best_depth
            best[better], best_depth[better] = candidate[better], depth[better]
        lift = np.where(np.isfinite(best_depth), best_depth, 0.0)
        best[:, 0] += lift
        planes[active] = best
    status = np.where(covered > 0, status, 1)
    return planes, status, covered


def footprint_penetration(surface, vehicle, x, y, yaw, planes, roll, pitch):
    """Deepest ground point above each plane over the tilted contact patches (>= 0), and the covered share."""
    high, covered, status = surface.highest_over_patches(x, y, yaw, patch_quads(vehicle, roll, pitch), planes)
    depth = np.where(status == 0, np.maximum(high, 0.0), np.nan)
    return depth, covered


def wheel_gap(surface, vehicle, x, y, yaw, planes):
    """Largest height of the plane above the ground at the six key points (NaN if none is on terrain)."""
    pts = key_points(vehicle, 6)
    z, _ = _heights(surface, x, y, yaw, pts)
    above = planes[:, [0]] + planes[:, [1]] * pts[:, 0] + planes[:, [2]] * pts[:, 1] - z
    with np.errstate(invalid="ignore"):
        gap = np.nanmax(np.where(np.isnan(above), -np.inf, above), axis=1)
    return np.where(np.isfinite(gap), np.maximum(gap, 0.0), np.nan)
