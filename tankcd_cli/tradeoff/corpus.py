"""A generated corpus of terrain families, and which key-point matcher each region class should get.

The rule ``auto`` ships (``matching.match.AUTO_RULE``) is the one this corpus supports: per
region class, the key-point matcher with the lowest median attitude error against the
rigid-hull reference (ties within 1 % go to the one fewest poses fail the reference's
certificate with: the cheapest once ``auto`` escalates). The corpus is deterministic
(fixed seeds): every family of ground a battlefield has, smooth and rough, at two amplitudes
and two post spacings, as DEM grids and as jittered TINs, with poses at random places and
headings, each counted in the class ``auto`` sees under it.

    python -m tankcd_cli.tradeoff.corpus      # prints the table the rule comes from
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from tankcd_cli.names import CLASS_NAMES
from tankcd_cli.tolerances import ATTITUDE_TOLERANCE_DEG

EXTENT = 60.0  # m, each terrain's side
POSES_PER_TERRAIN = 240
SPACINGS = (0.5, 1.0)  # m
AMPLITUDES = (0.5, 1.0)  # a scale on each family's heights
LAYOUTS = ("grid", "tin")
PAIRS = 5  # rounds of escalated against plain auto over the whole corpus, behind the escalation's ratio


def _waves(x, y, a):
    return a * 0.6 * np.sin(2 * np.pi * x / 17.0) * np.cos(2 * np.pi * y / 23.0)


def _hill(x, y, a):
    return a * 3.0 * np.exp(-((x - 30) ** 2 + (y - 30) ** 2) / (2 * 9.0 ** 2))


def _ridge(x, y, a):
    d = (x - 30) * np.cos(0.5) + (y - 30) * np.sin(0.5)
    return a * 2.0 * np.exp(-d ** 2 / (2 * 4.0 ** 2))


def _saddle(x, y, a):
    return a * 0.004 * ((x - 30) ** 2 - (y - 30) ** 2)


def _rough(x, y, a):
    rng = np.random.default_rng(7)
    z = np.zeros_like(x)
    for k in range(1, 7):  # a sum of random waves: ground rough at every scale down to ~3 m
        lam = 24.0 / k
        phase, angle = rng.uniform(0, 2 * np.pi, 2)
        z += 0.5 / k * np.sin(2 * np.pi * (x * np.cos(angle) + y * np.sin(angle)) / lam + phase)
    return a * z


def _steps(x, y, a):
    return a * 0.3 * np.floor((x + 0.3 * y) / 9.0)


def _ditch(x, y, a):
    d = np.abs((x - 30) * np.cos(0.3) + (y - 30) * np.sin(0.3))
    return -a * 1.5 * np.clip((1.6 - d) / 0.4, 0.0, 1.0)


def _berm(x, y, a):
    d = np.abs((x - 30) * np.cos(-0.4) + (y - 30) * np.sin(-0.4))
    return a * 1.0 * np.clip(1 - d / 2.0, 0.0, None)


def _craters(x, y, a):
    z = np.zeros_like(x)
    for cx, cy, r, depth in ((18, 20, 4.0, 1.2), (40, 38, 6.0, 1.8), (25, 45, 3.0, 0.9)):
        rr = np.hypot(x - cx, y - cy)
        z += np.where(rr < r, -depth * (1 - (rr / r) ** 2) ** 2, 0.0) + 0.4 * np.exp(-(((rr - r) / 1.2) ** 2))
    return a * z


def _knife(x, y, a):
    d = np.abs((x - 30) * np.cos(0.7) + (y - 30) * np.sin(0.7))
    return a * np.maximum(0.0, 1.0 * (1 - d / 2.5))


FAMILIES = {"waves": _waves, "hill": _hill, "ridge": _ridge, "saddle": _saddle, "rough": _rough, "steps": _steps,
            "ditch": _ditch, "berm": _berm, "craters": _craters, "knife_edge": _knife}


@dataclass(frozen=True)
class CorpusTerrain:
    family: str
    layout: str
    spacing: float
    amplitude: float

    @property
    def name(self) -> str:
        return f"{self.family} {self.layout} {self.spacing:g} m x{self.amplitude:g}"


def corpus_terrains() -> list[CorpusTerrain]:
    return [CorpusTerrain(f, lay, s, a) for f in FAMILIES for lay in LAYOUTS for s in SPACINGS for a in AMPLITUDES]


def build_surface(t: CorpusTerrain, vehicle, seed: int = 0):
    """The terrain's surface (classified for ``vehicle``), at UTM-like coordinates."""
    from tankcd_cli.terrain import synthetic as S

    f = FAMILIES[t.family]
    x0, y0 = 500_000.0, 4_500_000.0
    n = int(round(EXTENT / t.spacing)) + 1
    xs = np.arange(n) * t.spacing
    if t.layout == "grid":
        X, Y = np.meshgrid(xs, xs)
        return S.surface_of(S.dem_terrain(100.0 + f(X, Y, t.amplitude), origin=(x0, y0), spacing=t.spacing),
                            vehicle=vehicle)
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    X, Y = np.meshgrid(xs, xs)
    xy = np.column_stack([X.ravel(), Y.ravel()]) + rng.uniform(-0.35, 0.35, (n * n, 2)) * t.spacing
    faces = Delaunay(xy).simplices.astype(np.int64)
    a, b, c = xy[faces[:, 0]], xy[faces[:, 1]], xy[faces[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    faces[cw] = faces[cw][:, [0, 2, 1]]
    v = np.column_stack([xy[:, 0] + x0, xy[:, 1] + y0, 100.0 + f(xy[:, 0], xy[:, 1], t.amplitude)])
    return S.surface_of(S.mesh_terrain(v, faces), vehicle=vehicle)


def corpus_poses(vehicle, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Footprint centres and headings inside a terrain (a hull length from its edges)."""
    rng = np.random.default_rng(seed)
    margin = max(vehicle.hull_length, vehicle.track_length) + 1.0
    x = 500_000.0 + rng.uniform(margin, EXTENT - margin, POSES_PER_TERRAIN)
    y = 4_500_000.0 + rng.uniform(margin, EXTENT - margin, POSES_PER_TERRAIN)
    return x, y, rng.uniform(-np.pi, np.pi, POSES_PER_TERRAIN)


def _up(p) -> np.ndarray:
    return p.rotation[:, :, 2]


def _pct(a: np.ndarray, q: float) -> float:
    return float(np.percentile(a, q)) if len(a) else float("nan")


def _ratio_pairs(ratios: np.ndarray) -> tuple[float, float, float]:
    return float(np.median(ratios)), float(ratios.min()), float(ratios.max())


def measure_corpus(vehicle=None, progress=None, pairs: int = PAIRS) -> dict:
    """Per region class and key-point matcher: attitude and height errors against the reference,
    the share of poses that fail the reference's certificate, and the time, over the whole
    corpus; and ``auto`` with its escalation against the same reference.

    The winner of a class is the matcher with the lowest median attitude error; matchers within
    1 % of it tie, and of those the one that the fewest poses fail the certificate wins (each
    failure costs escalated ``auto`` a reference solve, ten to twenty key-point poses; on flat
    ground every matcher's median is 0, and the cheapest matcher is not the cheapest once its
    failures go to the reference). Counts decide, not times, so the rule is the same on any
    machine; the estimated escalated cost is in the table beside them. ``pairs``: rounds of
    escalated against plain ``auto`` behind the escalation's ratio (timing only: the counts, and
    so the winners, do not depend on it; 0: not timed).
    Returns {"rows": [...], "winners": {class: matcher}, "auto": [...], ...}.
    """
    from tankcd_cli.matching.match import (
        ESCALATED,
        KEY_POINT_MATCHERS,
        OK,
        certified,
        escalation_tolerance,
        match,
    )
    from tankcd_cli.vehicle import vehicle_preset

    vehicle = vehicle or vehicle_preset("t72")
    tol = escalation_tolerance(vehicle)
    say = progress or (lambda s: None)
    classes = range(len(CLASS_NAMES))
    att = {(c, m): [] for c in classes for m in KEY_POINT_MATCHERS + ("auto", "auto+")}
    dz = {key: [] for key in att}
    fails = {key: [] for key in att}
    seconds = dict.fromkeys(KEY_POINT_MATCHERS + ("reference", "auto", "auto+"), 0.0)
    poses = 0
    # escalated auto against plain, in turn on every terrain, ``pairs`` times: one whole-corpus ratio per round
    rounds = np.zeros((pairs, 2))
    for i, t in enumerate(corpus_terrains()):
        say(f"corpus: {t.name} ({i + 1}/{len(corpus_terrains())})")
        surface = build_surface(t, vehicle, seed=i)
        x, y, yaw = corpus_poses(vehicle, seed=1000 + i)
        s = time.perf_counter()
        ref = match(surface, vehicle, x, y, yaw, "reference", measure=False)
        seconds["reference"] += time.perf_counter() - s
        poses += len(x)
        for m in KEY_POINT_MATCHERS + ("auto", "auto+"):
            s = time.perf_counter()
            p = match(surface, vehicle, x, y, yaw, m.rstrip("+"), measure=False, escalate=m == "auto+")
            seconds[m] += time.perf_counter() - s
            ok = (p.status == OK) & (ref.status == OK) & (ref.region <= 2)
            if m == "auto+":
                failed = p.matcher >= ESCALATED
            elif m == "auto":
                failed = np.zeros(len(x), dtype=bool)
            else:
                failed = ~certified(surface, vehicle, x, y, yaw, p.plane, tol)
            cos = np.clip(np.einsum("ij,ij->i", _up(p)[ok], _up(ref)[ok]), -1.0, 1.0)
            for c in classes:
                sel = ref.region[ok] == c
                att[c, m].append(np.degrees(np.arccos(cos[sel])))
                dz[c, m].append(np.abs(p.position[ok, 2] - ref.position[ok, 2])[sel])
                fails[c, m].append(failed[ok][sel])
        for k in range(len(rounds)):
            for j, escalate in enumerate((False, True)):
                s = time.perf_counter()
                match(surface, vehicle, x, y, yaw, "auto", measure=False, escalate=escalate)
                rounds[k, j] += time.perf_counter() - s
    per_pose = {m: sec / max(poses, 1) * 1e6 for m, sec in seconds.items()}

    def row(c, m):
        a, h, f = (np.concatenate(d[c, m]) for d in (att, dz, fails))
        return {"class": CLASS_NAMES[c], "matcher": m, "poses": int(len(a)),
                "attitude_median_deg": float(np.median(a)) if len(a) else float("nan"),
                "attitude_p95_deg": _pct(a, 95), "attitude_max_deg": _pct(a, 100),
                "height_median_mm": float(np.median(h) * 1000) if len(h) else float("nan"),
                "height_p95_mm": _pct(h, 95) * 1000, "height_max_mm": _pct(h, 100) * 1000,
                "failing_share": float(f.mean()) if len(f) else float("nan"),
                "us_per_pose": per_pose[m.rstrip("+") if m != "auto+" else m]}

    rows, winners, auto = [], {}, []
    for c in classes:
        mine = [row(c, m) for m in KEY_POINT_MATCHERS]
        for r in mine:  # what escalated ``auto`` would cost a pose of this class with this matcher
            r["escalated_us_per_pose"] = r["us_per_pose"] + r["failing_share"] * per_pose["reference"]
        rows += mine
        scored = [r for r in mine if r["poses"]]
        if scored:
            best = min(r["attitude_median_deg"] for r in scored)
            tied = [r for r in scored if r["attitude_median_deg"] <= best * 1.01 + 1e-12]
            winners[CLASS_NAMES[c]] = min(tied, key=lambda r: r["failing_share"])["matcher"]
        else:
            winners[CLASS_NAMES[c]] = None
        for m in ("auto", "auto+"):
            r = row(c, m)
            r["matcher"] = "auto, escalated" if m == "auto+" else "auto, plain"
            auto.append(r)
    every = {m: np.concatenate([np.concatenate(att[c, m]) for c in classes]) for m in ("auto", "auto+")}
    return {"rows": rows, "winners": winners, "auto": auto, "poses": poses, "terrains": len(corpus_terrains()),
            "reference_us_per_pose": per_pose["reference"], "auto_us_per_pose": per_pose["auto"],
            "escalated_us_per_pose": per_pose["auto+"], "tolerance_m": tol,
            "escalation_ratio_pairs": _ratio_pairs(rounds[:, 1] / rounds[:, 0]) if pairs else (float("nan"),) * 3,
            "escalation_rounds": pairs,
            "escalated_share": float(np.mean(np.concatenate([np.concatenate(fails[c, "auto+"]) for c in classes]))),
            "auto_attitude_p95_deg": _pct(every["auto"], 95), "escalated_attitude_p95_deg": _pct(every["auto+"], 95)}


def corpus_table(result: dict) -> str:
    """The per-class table (markdown), the rule it supports, and ``auto`` plain and escalated."""
    lines = [f"Corpus: {result['terrains']} terrains ({', '.join(FAMILIES)}; grids and jittered TINs at "
             f"{' and '.join(f'{s:g}' for s in SPACINGS)} m posts, two amplitudes), {result['poses']:,} poses; "
             "errors against the rigid-hull reference "
             f"({result['reference_us_per_pose']:.1f} us a pose). \"failing\": the share that fails the "
             f"reference's certificate ({result['tolerance_m'] * 1000:.0f} mm at the footprint's corners, "
             f"{ATTITUDE_TOLERANCE_DEG:g} deg of attitude) and "
             "goes to the reference when escalated; \"escalated\": the matcher's time plus that share of the "
             "reference's.", "",
             "| class | matcher | poses | attitude median / p95, deg | height median / p95, mm | failing | "
             "us a pose | escalated, us a pose |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in result["rows"]:
        win = " **(rule)**" if result["winners"].get(r["class"]) == r["matcher"] else ""
        lines.append(f"| {r['class']} | {r['matcher']}{win} | {r['poses']:,} | {r['attitude_median_deg']:.3f} / "
                     f"{r['attitude_p95_deg']:.2f} | {r['height_median_mm']:.1f} / {r['height_p95_mm']:.1f} | "
                     f"{r['failing_share']:.1%} | {r['us_per_pose']:.2f} | {r['escalated_us_per_pose']:.2f} |")
    lines += ["", "Rule: " + ", ".join(f"{c} -> {m}" for c, m in result["winners"].items()) + ".", "",
              "`auto` with that rule, plain and escalated (every key-point pose that fails the certificate "
              "solved again by the reference):", "",
              "| class | auto | poses | attitude median / p95 / max, deg | height median / p95 / max, mm | "
              "escalated share |", "| --- | --- | --- | --- | --- | --- |"]
    for r in result["auto"]:
        lines.append(f"| {r['class']} | {r['matcher']} | {r['poses']:,} | {r['attitude_median_deg']:.3f} / "
                     f"{r['attitude_p95_deg']:.2f} / {r['attitude_max_deg']:.2f} | {r['height_median_mm']:.1f} / "
                     f"{r['height_p95_mm']:.1f} / {r['height_max_mm']:.1f} | "
                     f"{r['failing_share']:.1%} |")
    from tankcd_cli.tradeoff.timing import cost_text

    med, lo, hi = result.get("escalation_ratio_pairs", (float("nan"),) * 3)
    rounds = result.get("escalation_rounds", PAIRS)
    timed = (f"in {rounds} rounds of the two in turn on every terrain, escalated auto takes "
             f"{cost_text(med, lo, hi, 'plain auto')} over the whole corpus" if rounds else
             "escalated auto against plain in turn: not timed in this run")
    lines += ["", f"Whole corpus: attitude p95 {result['auto_attitude_p95_deg']:.2f} deg plain, "
              f"{result['escalated_attitude_p95_deg']:.2f} deg escalated; {result['escalated_share']:.1%} of the "
              f"poses escalated; {result['auto_us_per_pose']:.2f} against {result['escalated_us_per_pose']:.2f} us "
              f"a pose (matching alone, without the penetration and gap columns a replay adds); {timed}."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    import sys

    print(corpus_table(measure_corpus(progress=lambda s: print(s, file=sys.stderr))))
