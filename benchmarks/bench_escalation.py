"""Benchmark: what `auto`'s escalation buys and costs, against the rigid-hull reference.

    python benchmarks/bench_escalation.py [--out benchmarks/results/escalation.md]

Two trajectories on the sample battlefield: the sample patrol (sample_data/patrol.csv) and a
65 536-pose random walk (the one benchmarks/bench_replay.py replays). For each: attitude and
height errors of `auto` plain (`--no-escalate`) and escalated against `reference` on the same
poses, the share of poses escalated, and the time of the matching stage in this process
(penetration and gap measured, as a replay does), plain and escalated alternated, medians of
7 with the ratio; peak memory of the process at the end.
"""

from __future__ import annotations

import argparse
import os
import resource
import time

import numpy as np

from _report import save_report
from bench_replay import random_walk

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLE = os.path.join(os.path.dirname(HERE), "sample_data")


def patrol():
    rows = np.loadtxt(os.path.join(SAMPLE, "patrol.csv"), delimiter=",", skiprows=1, usecols=(1, 2, 3))
    return rows[:, 0], rows[:, 1], np.radians(rows[:, 2])


def errors(p, ref, OK):
    """Attitude p95 and max (deg), height error p95 and max (mm), penetration max (mm)."""
    ok = (p.status == OK) & (ref.status == OK)
    att = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", p.rotation[ok, :, 2], ref.rotation[ok, :, 2]), -1, 1)))
    dz = np.abs(p.position[ok, 2] - ref.position[ok, 2]) * 1000
    return np.percentile(att, 95), att.max(), np.percentile(dz, 95), dz.max(), np.nanmax(p.penetration[ok]) * 1000


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(HERE, "results", "escalation.md"))
    ap.add_argument("--repeats", type=int, default=7)
    a = ap.parse_args()
    from tankcd_cli.matching.match import ESCALATED, OK, escalation_tolerance, match
    from tankcd_cli.tolerances import ATTITUDE_TOLERANCE_DEG
    from tankcd_cli.terrain import synthetic as S
    from tankcd_cli.terrain.mesh.classify import read_mesh
    from tankcd_cli.vehicle import vehicle_preset

    vehicle = vehicle_preset("t72")
    surface = S.surface_of(read_mesh(os.path.join(SAMPLE, "battlefield.asc")), vehicle=vehicle)
    lines = ["# Benchmark: auto's escalation by certificate", "",
             f"T-72 on the sample battlefield; certificate tolerance {escalation_tolerance(vehicle) * 1000:.0f} mm "
             f"at the footprint's corners and {ATTITUDE_TOLERANCE_DEG:g} deg of attitude. Errors against "
             "`reference` on the same poses (attitude: the angle "
             "between the hull's up axes). Times: the matching stage in one process (penetration and gap "
             f"measured), plain and escalated alternated, medians of {a.repeats}.", "",
             "| trajectory | poses | plain: attitude p95 / max, deg; height p95 / max, mm; penetration max, mm | escalated | "
             "escalated share | plain / escalated / reference time | escalated / plain |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for name, (x, y, yaw) in (("sample patrol", patrol()), ("random walk", random_walk(65_536))):
        ref = match(surface, vehicle, x, y, yaw, "reference")
        plain = match(surface, vehicle, x, y, yaw, "auto", escalate=False)
        esc = match(surface, vehicle, x, y, yaw, "auto")
        tp, te, tr = [], [], []
        for _ in range(a.repeats):
            for out, kw in ((tp, {"escalate": False}), (te, {}), (tr, None)):
                s = time.perf_counter()
                if kw is None:
                    match(surface, vehicle, x, y, yaw, "reference")
                else:
                    match(surface, vehicle, x, y, yaw, "auto", **kw)
                out.append(time.perf_counter() - s)
        ep, em, hp, hm, pm = errors(plain, ref, OK)
        xp, xm, xhp, xhm, xpm = errors(esc, ref, OK)
        ratio = float(np.median(np.array(te) / np.array(tp)))
        lines.append(f"| {name} | {len(x):,} | {ep:.2f} / {em:.2f}; {hp:.1f} / {hm:.1f}; {pm:.1f} | {xp:.2f} / {xm:.2f}; "
                     f"{xhp:.1f} / {xhm:.1f}; {xpm:.1f} | {np.mean(esc.matcher >= ESCALATED):.1%} | "
                     f"{np.median(tp) * 1e3:.1f} / {np.median(te) * 1e3:.1f} / {np.median(tr) * 1e3:.1f} ms | "
                     f"{ratio:.2f}x |")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    lines += ["", f"Peak memory of the process: {peak:,.0f} MB. The whole-process cost of escalating, start-up, "
              "reading and writing included, is in benchmarks/results/replay.md."]
    save_report("\n".join(lines + [""]), a.out)


if __name__ == "__main__":
    main()
