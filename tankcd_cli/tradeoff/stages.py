"""The five measured stages of the trade-off report, each variant timed and judged against an
independent truth, and what they record.

Truths: curvature against the closed-form H of analytic surfaces; matching
against the rigid-hull reference (dense contact over every terrain triangle
under the tracks); obstacle trees against testing every triangle pair; the
two-plane internal test against the exact cylinder test; the headline, ``auto``
against always-reference on a whole replay. Times are medians of ``repeats``
runs after one warm-up (caches and first-touch pages), with the fastest and
slowest run as the spread (``tradeoff.timing``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.query import collide, collide_brute_force
from tankcd_cli.collision.internal import gun_hits_drums
from tankcd_cli.geometry.pose import attitude_from_slopes, rotation_matrix
from tankcd_cli.matching.match import (
    ESCALATED,
    OFF,
    PLACED_BY,
    escalation_tolerance,
    footprint_penetration,
    match,
    wheel_gap,
)
from tankcd_cli.terrain import synthetic
from tankcd_cli.terrain.curvature.mean import METHODS, mean_curvature
from tankcd_cli.terrain.mesh.footprint_average import footprint_curvature, vertex_areas
from tankcd_cli.terrain.regions import classify_values, default_thresholds
from tankcd_cli.tolerances import ATTITUDE_TOLERANCE_DEG
from tankcd_cli.tradeoff.peers import peer_query
from tankcd_cli.tradeoff.timing import paired, timed
from tankcd_cli.vehicle_mesh import vehicle_mesh


@dataclass
class Record:
    """One measure of one variant: a row of tradeoff.csv."""

    stage: str
    case: str
    variant: str
    measure: str
    value: float
    unit: str
    truth: str
    spread_lo: float = float("nan")
    spread_hi: float = float("nan")


@dataclass
class Point:
    """One variant on a stage's error-versus-time plot."""

    stage: str
    variant: str
    seconds: float  # per query
    seconds_lo: float
    seconds_hi: float
    error: float
    is_truth: bool = False


@dataclass
class Results:
    records: list = field(default_factory=list)
    points: list = field(default_factory=list)
    axes: dict = field(default_factory=dict)  # stage -> (query name, error name)
    headline: dict = field(default_factory=dict)
    corpus: dict = field(default_factory=dict)  # the per-class matcher table (tradeoff.corpus)
    rates: list = field(default_factory=list)  # one RateRow per sampling rate (``rate_stage``)
    gates: list = field(default_factory=list)  # one GateRow per replay with and without the gates (``tradeoff.gates``)
    machine: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Budget:
    """Sizes and repeats: ``quick`` for CI (under a minute), ``full`` for the report."""

    repeats: int
    curvature_half_extent: float
    match_poses: int
    path_step: float
    collide_poses: int
    brute_poses: int
    internal_step_deg: float
    pair_repeats: int  # pairs behind each ratio (the headline's, the sampling rates')
    turn_seconds: float = 0.1  # the least time of each turn of a pair (``paired``'s min_seconds)


QUICK = Budget(repeats=3, curvature_half_extent=15.0, match_poses=600, path_step=0.25, collide_poses=120,
               brute_poses=40, internal_step_deg=2.0, pair_repeats=7)
FULL = Budget(repeats=7, curvature_half_extent=50.0, match_poses=20_000, path_step=0.05, collide_poses=3000,
              brute_poses=400, internal_step_deg=0.25, pair_repeats=15)


def _pct(values: np.ndarray, q: float) -> float:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(np.percentile(values, q)) if len(values) else float("nan")


# --- curvature ----------------------------------------------------------------------

def curvature_stage(res: Results, vehicle, budget: Budget, say) -> None:
    truth = "closed-form H of the analytic surface"
    res.axes["curvature"] = ("vertex", "median |H - H_true| / median |H_true|")
    fields = [synthetic.gaussian_hill(2.0, 8.0), synthetic.sinusoid(0.8, 30.0, 24.0), synthetic.sphere_cap(150.0)]
    thresholds = default_thresholds(vehicle)
    half = budget.curvature_half_extent
    errors = {m: [] for m in METHODS}
    times = {m: [] for m in METHODS}
    for fld in fields:
        for kind in ("grid", "jittered"):
            if kind == "grid":
                V, F, xy = synthetic.grid_mesh(fld, half, 1.0)
            else:
                V, F, xy = synthetic.jittered_mesh(fld, half, 1.0, seed=1)
            case = f"{fld.name}, {kind} 1 m, {len(V):,} vertices"
            say(f"curvature: {case}")
            exact = fld.mean_curvature(xy[:, 0], xy[:, 1])
            interior = (np.abs(xy) < half - 3.0).all(axis=1)
            area = vertex_areas(V, F)
            exact_class = classify_values(footprint_curvature(V, exact, area, vehicle)[0], thresholds)
            scale = float(np.median(np.abs(exact[interior])))
            for method in METHODS:
                t, lo, hi = timed(lambda: mean_curvature(V, F, method), budget.repeats)
                H = mean_curvature(V, F, method)
                err = np.abs(H - exact)
                classes = classify_values(footprint_curvature(V, H, area, vehicle)[0], thresholds)
                n = len(V)
                rel = float(np.median(err[interior])) / scale
                errors[method].append(rel)
                times[method].append((t / n, lo / n, hi / n))
                for measure, value, unit in (
                        ("error_median_interior", float(np.median(err[interior])), "1/m"),
                        ("error_p95_interior", _pct(err[interior], 95), "1/m"),
                        ("error_p95_border_band", _pct(err[~interior], 95), "1/m"),
                        ("error_median_relative", rel, "1"),
                        ("class_changed_share", float(np.mean(classes != exact_class)), "1")):
                    res.records.append(Record("curvature", case, method, measure, value, unit, truth))
                res.records.append(Record("curvature", case, method, "time_per_vertex", t / n, "s", truth, lo / n,
                                          hi / n))
    for method in METHODS:
        t = np.array(times[method])
        res.points.append(Point("curvature", method, float(np.median(t[:, 0])), float(np.median(t[:, 1])),
                                float(np.median(t[:, 2])), float(np.median(errors[method]))))


# --- matching -----------------------------------------------------------------------

TRIPOD = "tripod"  # the common simulator ground clamp: three vertical probes, a plane through them


def tripod_planes(surface, vehicle, x, y, yaw) -> tuple[np.ndarray, np.ndarray]:
    """Planes (N, 3) through the ground under the front track ends and the rear centre, and on-terrain (N,)."""
    h, g = vehicle.track_length / 2, vehicle.track_gauge / 2
    pts = np.array([[h, g], [h, -g], [-h, 0.0]])
    z = surface.heights_at(x, y, yaw, pts)
    on = np.isfinite(z).all(axis=1)
    M = np.column_stack([np.ones(3), pts])  # a + b u + c v = z at each probe
    return z @ np.linalg.inv(M).T, on


def _tripod_poses(surface, vehicle, x, y, yaw):
    plane, on = tripod_planes(surface, vehicle, x, y, yaw)
    roll, pitch = attitude_from_slopes(plane[:, 1], plane[:, 2])
    pen = np.full(len(x), np.nan)
    gap = np.full(len(x), np.nan)
    idx = np.flatnonzero(on)
    pen[idx], _ = footprint_penetration(surface, vehicle, x[idx], y[idx], yaw[idx], plane[idx], roll[idx], pitch[idx])
    gap[idx] = wheel_gap(surface, vehicle, x[idx], y[idx], yaw[idx], plane[idx])
    return plane, roll, pitch, pen, gap, on


def angle_deg(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle (N,) between unit vectors (N, 3), degrees; exact 0 for equal vectors (arccos is not, near 1)."""
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.einsum("ij,ij->i", u, v)))


def _up(roll, pitch, yaw):
    return rotation_matrix(roll, pitch, yaw)[:, :, 2]


MATCH_VARIANTS = ("two_point", "four_point", "six_point", "wheel_stations", "auto", TRIPOD, "reference")  # auto: plain


def _match_all(surface, vehicle, x, y, yaw) -> dict:
    """Every variant's poses: {variant: (z (N,), up (N, 3), roll, pitch, penetration, gap, ok (N,))}."""
    out = {}
    for variant in MATCH_VARIANTS:
        if variant == TRIPOD:
            plane, roll, pitch, pen, gap, ok = _tripod_poses(surface, vehicle, x, y, yaw)
            out[variant] = (plane[:, 0], _up(roll, pitch, yaw), roll, pitch, pen, gap, ok)
        else:
            p = match(surface, vehicle, x, y, yaw, variant, measure=True, escalate=False)
            out[variant] = (p.position[:, 2], _up(p.roll, p.pitch, p.yaw), p.roll, p.pitch, p.penetration, p.gap,
                            p.status != OFF)
    return out


def _interior_poses(surface, vehicle, n, rng):
    lo, hi = surface.bounds()
    margin = vehicle.hull_length
    x = rng.uniform(lo[0] + margin, hi[0] - margin, n)
    y = rng.uniform(lo[1] + margin, hi[1] - margin, n)
    return x, y, rng.uniform(-np.pi, np.pi, n)


def _path(surface, vehicle, step):
    """A straight west-east drive through the middle of the terrain, heading east."""
    lo, hi = surface.bounds()
    margin = vehicle.hull_length
    x = np.arange(lo[0] + margin, hi[0] - margin, step)
    return x, np.full(len(x), 0.5 * (lo[1] + hi[1]) + 0.37), np.zeros(len(x))


def matching_stage(res: Results, surfaces: list, vehicle, budget: Budget, say, seed: int = 5) -> None:
    truth = "reference (rigid hull on every terrain triangle under the tracks)"
    res.axes["matching"] = ("pose", "median attitude error vs reference, deg")
    rng = np.random.default_rng(seed)
    att_all = {v: [] for v in MATCH_VARIANTS}
    t_all = {v: [] for v in MATCH_VARIANTS}
    for name, surface in surfaces:
        say(f"matching: {name}")
        x, y, yaw = _interior_poses(surface, vehicle, budget.match_poses, rng)
        got = _match_all(surface, vehicle, x, y, yaw)
        region = surface.region_under(x, y, yaw, vehicle.track_length, vehicle.footprint_width)
        zr, upr = got["reference"][0], got["reference"][1]
        for variant in MATCH_VARIANTS:
            z, up, roll, pitch, pen, gap, ok = got[variant]
            ok = ok & got["reference"][6]
            att = angle_deg(up, upr)
            dz = np.abs(z - zr)
            att_all[variant].append(att[ok])
            for cls, label in ((None, "all"), (0, "flat"), (1, "general"), (2, "uneven")):
                sel = ok if cls is None else ok & (region == cls)
                if not sel.any():
                    continue
                case = f"{name}: {label} ({int(sel.sum()):,} poses)"
                for measure, value, unit in (
                        ("attitude_error_median", float(np.median(att[sel])), "deg"),
                        ("attitude_error_p95", _pct(att[sel], 95), "deg"),
                        ("height_error_median", float(np.median(dz[sel])), "m"),
                        ("height_error_p95", _pct(dz[sel], 95), "m"),
                        ("penetration_median", _pct(pen[sel], 50), "m"),
                        ("penetration_p95", _pct(pen[sel], 95), "m"),
                        ("gap_median", _pct(gap[sel], 50), "m"),
                        ("gap_p95", _pct(gap[sel], 95), "m")):
                    res.records.append(Record("matching", case, variant, measure, value, unit, truth))
        # time per pose, as replay pays it for the pose alone (penetration and gap are measured apart)
        for variant in MATCH_VARIANTS:
            if variant == TRIPOD:
                t, lo, hi = timed(lambda: tripod_planes(surface, vehicle, x, y, yaw), budget.repeats)
            else:
                t, lo, hi = timed(lambda: match(surface, vehicle, x, y, yaw, variant, measure=False, escalate=False),
                                  budget.repeats)
            n = len(x)
            t_all[variant].append((t / n, lo / n, hi / n))
            res.records.append(Record("matching", f"{name}: time ({n:,} poses)", variant, "time_per_pose", t / n, "s",
                                      truth, lo / n, hi / n))
        # jitter: step-to-step attitude change along a straight drive (independent of the reference)
        px, py, pyaw = _path(surface, vehicle, budget.path_step)
        path = _match_all(surface, vehicle, px, py, pyaw)
        for variant in MATCH_VARIANTS:
            _, up, _, _, _, _, ok = path[variant]
            step = angle_deg(up[1:], up[:-1])
            step = step[ok[1:] & ok[:-1]]
            case = f"{name}: straight drive, {budget.path_step:g} m steps"
            res.records.append(Record("matching", case, variant, "jitter_p95", _pct(step, 95), "deg/step",
                                      "none (a property of the path)"))
            res.records.append(Record("matching", case, variant, "jitter_max", _pct(step, 100), "deg/step",
                                      "none (a property of the path)"))
    for variant in MATCH_VARIANTS:
        t = np.array(t_all[variant])
        res.points.append(Point("matching", variant, float(np.median(t[:, 0])), float(np.median(t[:, 1])),
                                float(np.median(t[:, 2])), float(np.median(np.concatenate(att_all[variant]))),
                                is_truth=variant == "reference"))


# --- obstacle collision ---------------------------------------------------------------

# (name, k, AABB levels): the hybrids are k = 18 below their AABB levels (the scene default is 2 levels)
LAYOUTS = (("AABB only", 6, 0), ("k-DOP 14 only", 14, 0), ("k-DOP 18 only", 18, 0), ("k-DOP 26 only", 26, 0),
           ("hybrid 1 AABB level", 18, 1), ("hybrid 2 AABB levels", 18, 2),
           ("hybrid 3 AABB levels", 18, 3), ("hybrid 4 AABB levels", 18, 4))


def collision_poses(surface, vehicle, obstacle_tris: list, n: int, rng):
    """Poses (R (N, 3, 3), t (N, 3)) on the terrain around the obstacles (about half of them touching)."""
    lo = np.array([t.reshape(-1, 3).min(axis=0) for t in obstacle_tris])
    hi = np.array([t.reshape(-1, 3).max(axis=0) for t in obstacle_tris])
    which = rng.integers(0, len(lo), 4 * n)
    reach = vehicle.hull_length / 2
    x = rng.uniform(lo[which, 0] - reach, hi[which, 0] + reach)
    y = rng.uniform(lo[which, 1] - reach, hi[which, 1] + reach)
    yaw = rng.uniform(-np.pi, np.pi, len(x))
    p = match(surface, vehicle, x, y, yaw, "auto", measure=False, escalate=False)
    keep = np.flatnonzero(p.status != OFF)[:n]
    return p.rotation[keep], p.position[keep]


def collision_stage(res: Results, surface, vehicle, obstacle_tris: list, budget: Budget, say, seed: int = 9) -> None:
    truth = "every triangle pair tested (brute force)"
    res.axes["collision"] = ("pose", "triangle tests that find no contact (volume false positives)")
    if not obstacle_tris:
        say("collision: the scene has no obstacles: stage skipped")
        return
    rng = np.random.default_rng(seed)
    tank, _ = vehicle_mesh(vehicle, 2)
    world = np.concatenate(obstacle_tris)
    R, t = collision_poses(surface, vehicle, obstacle_tris, budget.collide_poses, rng)
    n = len(R)
    case = f"{len(tank):,}-triangle tank vs {len(world):,} obstacle triangles, {n:,} poses"
    say(f"collision: {case}")
    nb = min(budget.brute_poses, n)
    brute = collide_brute_force(tank, world, R[:nb], t[:nb]) > 0
    res.records.append(Record("collision", case, "brute force", "hit_share", float(brute.mean()), "1", truth))
    for label, k, levels in LAYOUTS:
        a = build_tree(tank, k=k, aabb_levels=levels)
        b = build_tree(world, k=k, aabb_levels=levels)
        first = collide(a, b, R, t)
        every = collide(a, b, R, t, all_contacts=True)
        tm, lo, hi = timed(lambda: collide(a, b, R, t), budget.repeats)
        disagree = float(np.mean(first.hit[:nb] != brute))
        false_pos = 1.0 - every.found.sum() / max(every.tri_tests.sum(), 1)
        for measure, value, unit in (("node_tests_per_pose", float(every.node_tests.mean()), "1"),
                                     ("leaf_tests_per_pose", float(every.tri_tests.mean()), "1"),
                                     ("node_tests_first_contact", float(first.node_tests.mean()), "1"),
                                     ("volume_false_positive_share", float(false_pos), "1"),
                                     ("disagreement_with_truth", disagree, "1")):
            res.records.append(Record("collision", case, label, measure, value, unit, truth))
        res.records.append(Record("collision", case, label, "time_per_pose", tm / n, "s", truth, lo / n, hi / n))
        res.points.append(Point("collision", label, tm / n, lo / n, hi / n, float(false_pos)))
    for peer in ("python-fcl", "coal"):
        peer_run = peer_query(peer, tank, world, R, t)
        if peer_run is None:
            res.records.append(Record("collision", case, peer, "not_installed", float("nan"), "", truth))
            continue
        run = peer_run[0]
        tm, lo, hi = timed(run, budget.repeats)
        hits = run()
        res.records.append(Record("collision", case, peer, "disagreement_with_truth",
                                  float(np.mean(hits[:nb] != brute)),
                                  "1", truth))
        res.records.append(Record("collision", case, peer, "time_per_pose", tm / n, "s", truth, lo / n, hi / n))


# --- internal -------------------------------------------------------------------------

def internal_stage(res: Results, vehicle, budget: Budget, say) -> None:
    truth = "exact finite-cylinder test (GJK distance)"
    res.axes["internal"] = ("check", "disagreement with the exact test (share of checks)")
    if not vehicle.fuel_drums:
        say("internal: the vehicle carries no drums: stage skipped")
        return
    step = budget.internal_step_deg
    az, el = np.meshgrid(np.arange(-180.0, 180.0, step),
                         np.arange(vehicle.gun_min_deg - 2, vehicle.gun_max_deg + step / 2, step / 4))
    az, el = np.radians(az.ravel()), np.radians(el.ravel())
    n = len(az)
    case = f"{vehicle.name}: {n:,} (azimuth, elevation) pairs"
    say(f"internal: {case}")
    exact = gun_hits_drums(vehicle, az, el, "exact").any(axis=1)
    for method in ("exact", "projection"):
        tm, lo, hi = timed(lambda: gun_hits_drums(vehicle, az, el, method), budget.repeats)
        hit = gun_hits_drums(vehicle, az, el, method).any(axis=1)
        false_alarm = float(np.mean(hit & ~exact))
        missed = float(np.mean(~hit & exact))
        for measure, value in (("hit_share", float(hit.mean())), ("false_alarm_share", false_alarm),
                               ("missed_share", missed), ("disagreement", false_alarm + missed)):
            res.records.append(Record("internal", case, method, measure, value, "1", truth))
        res.records.append(Record("internal", case, method, "time_per_check", tm / n, "s", truth, lo / n, hi / n))
        res.points.append(Point("internal", method, tm / n, lo / n, hi / n, false_alarm + missed,
                                is_truth=method == "exact"))


# --- the headline: auto against always-reference on a whole replay ----------------------

def headline_stage(res: Results, surface, vehicle, x, y, yaw, budget: Budget, say, name: str) -> None:
    say(f"headline: auto vs reference on {name}")
    n = len(x)

    def plain():
        return match(surface, vehicle, x, y, yaw, "auto", measure=True, escalate=False)

    def reference():
        return match(surface, vehicle, x, y, yaw, "reference", measure=True)

    def escalated():
        return match(surface, vehicle, x, y, yaw, "auto", measure=True, escalate=True)

    # timed in pairs, in turn: a ratio of two medians taken minutes apart is at the mercy of the machine
    vs_ref = paired(plain, reference, budget.pair_repeats, min_seconds=budget.turn_seconds)
    vs_esc = paired(plain, escalated, budget.pair_repeats, min_seconds=budget.turn_seconds)
    t_auto, t_ref, t_esc = vs_ref.a, vs_ref.b, vs_esc.b
    a = match(surface, vehicle, x, y, yaw, "auto", measure=True, escalate=False)
    r = match(surface, vehicle, x, y, yaw, "reference", measure=True)
    e = match(surface, vehicle, x, y, yaw, "auto", measure=True, escalate=True)
    ok_e = (e.status != OFF) & (r.status != OFF)
    att_e = angle_deg(_up(e.roll, e.pitch, e.yaw)[ok_e], _up(r.roll, r.pitch, r.yaw)[ok_e])
    dz_e = np.abs(e.position[ok_e, 2] - r.position[ok_e, 2])
    ok = (a.status != OFF) & (r.status != OFF)
    att = angle_deg(_up(a.roll, a.pitch, a.yaw)[ok], _up(r.roll, r.pitch, r.yaw)[ok])
    dz = np.abs(a.position[ok, 2] - r.position[ok, 2])
    used = np.bincount(a.matcher, minlength=len(PLACED_BY))
    truth = "reference (rigid hull on every terrain triangle under the tracks)"
    h = {"trajectory": name, "poses": n,
         "auto_seconds": t_auto[0], "auto_spread": t_auto[1:], "reference_seconds": t_ref[0],
         "reference_spread": t_ref[1:],
         "speedup": vs_ref.ratio, "speedup_spread": (vs_ref.ratio_lo, vs_ref.ratio_hi),
         "time_saved_share": 1.0 - 1.0 / vs_ref.ratio,
         "time_saved_share_spread": (1.0 - 1.0 / vs_ref.ratio_lo, 1.0 - 1.0 / vs_ref.ratio_hi),
         "escalation_cost": vs_esc.ratio, "escalation_cost_spread": (vs_esc.ratio_lo, vs_esc.ratio_hi),
         "attitude_error_median_deg": float(np.median(att)), "attitude_error_p95_deg": _pct(att, 95),
         "attitude_error_max_deg": _pct(att, 100),
         "height_error_median_m": float(np.median(dz)), "height_error_p95_m": _pct(dz, 95),
         "height_error_max_m": _pct(dz, 100),
         "penetration_p95_auto_m": _pct(a.penetration[ok], 95),
         "penetration_p95_reference_m": _pct(r.penetration[ok], 95),
         "matchers_used": {m: int(c) for m, c in zip(PLACED_BY, used) if c},
         "escalated_seconds": t_esc[0], "escalated_spread": t_esc[1:],
         "escalated_share": float(np.mean(e.matcher >= ESCALATED)) if n else 0.0,
         "escalated_attitude_error_median_deg": float(np.median(att_e)) if len(att_e) else float("nan"),
         "escalated_attitude_error_p95_deg": _pct(att_e, 95), "escalated_attitude_error_max_deg": _pct(att_e, 100),
         "escalated_height_error_median_m": float(np.median(dz_e)) if len(dz_e) else float("nan"),
         "escalated_height_error_p95_m": _pct(dz_e, 95), "escalated_height_error_max_m": _pct(dz_e, 100),
         "escalated_penetration_p95_m": _pct(e.penetration[ok_e], 95),
         "escalation_tolerance_m": escalation_tolerance(vehicle), "attitude_tolerance_deg": ATTITUDE_TOLERANCE_DEG}
    res.headline = h
    for key in ("auto_seconds", "reference_seconds", "speedup", "escalation_cost", "time_saved_share",
                "attitude_error_median_deg",
                "attitude_error_p95_deg", "attitude_error_max_deg", "height_error_median_m", "height_error_p95_m",
                "height_error_max_m", "escalated_seconds", "escalated_share", "escalated_attitude_error_p95_deg",
                "escalated_height_error_max_m"):
        unit = ("s" if key.endswith("seconds") else "deg" if key.endswith("deg") else
                "m" if key.endswith("_m") else "1")
        spread = h.get(key.replace("seconds", "spread") if unit == "s" else f"{key}_spread", (float("nan"),) * 2)
        res.records.append(Record("headline", f"{name} ({n:,} poses)", "auto vs reference", key, float(h[key]), unit,
                                  truth, *spread))
