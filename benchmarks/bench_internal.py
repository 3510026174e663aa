"""Benchmark: gun barrel against the rear drums, the paper's projection test against the exact test.

    python benchmarks/bench_internal.py [--out benchmarks/results/internal.md]

Over every turret azimuth (0.5 deg steps) and gun elevation in the T-72's
range (0.1 deg steps): how often the projection test reports a collision the
exact test rejects (false alarms; it never misses one: the tests check that),
and what each costs per check.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(HERE, "results", "internal.md"))
    args = ap.parse_args()
    from tankcd_cli.collision.internal import elevation_envelope, gun_hits_drums
    from tankcd_cli.vehicle import vehicle_preset

    v = vehicle_preset("t72")
    A, E = np.meshgrid(np.arange(0, 360, 0.5), np.arange(v.gun_min_deg, v.gun_max_deg + 1e-9, 0.1))
    az, el = np.radians(A.ravel()), np.radians(E.ravel())
    n = len(az)
    rows = {}
    for method in ("exact", "projection"):
        gun_hits_drums(v, az[:10], el[:10], method)
        ts = []
        for _ in range(3):
            s = time.perf_counter()
            hit = gun_hits_drums(v, az, el, method).any(axis=1)
            ts.append(time.perf_counter() - s)
        rows[method] = (hit, float(np.median(ts)))
    exact, projection = rows["exact"][0], rows["projection"][0]
    false_alarm = projection & ~exact
    missed = exact & ~projection
    s = time.perf_counter()
    env = elevation_envelope(v, np.arange(0, 360, 1.0))
    env_t = time.perf_counter() - s
    env_p = elevation_envelope(v, np.arange(0, 360, 1.0), method="projection")
    lines = ["# Benchmark: gun barrel against the rear fuel drums", "",
             f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores. T-72 preset, "
             f"{n:,} (azimuth, elevation) pairs, each against both drums; medians of 3.", "",
             "| method | us per check (both drums) | collisions reported | false alarms | missed |",
             "| --- | --- | --- | --- | --- |"]
    for method in ("exact", "projection"):
        hit, t = rows[method]
        lines.append(f"| {method} | {t / n * 1e6:.2f} | {hit.sum():,} | "
                     f"{false_alarm.sum() if method == 'projection' else 0:,} | {missed.sum() if method == 'projection' else 0} |")
    lim, limp = env["min_elevation"], env_p["min_elevation"]
    both = np.isfinite(lim) & np.isfinite(limp)
    lines += ["", f"Projection false alarms: {false_alarm.sum() / max(projection.sum(), 1):.1%} of its reported "
              f"collisions ({false_alarm.mean():.2%} of all checks).",
              f"Envelope (1 deg azimuth steps, 0.01 deg bisection, exact test): {env_t:.2f} s; the projection "
              f"test's envelope is up to {np.max(limp[both] - lim[both]):.2f} deg more restrictive "
              f"(drums limit {env['limited'].sum()} of 360 azimuths exactly, {env_p['limited'].sum()} by projection).", ""]
    save_report("\n".join(lines), args.out)


if __name__ == "__main__":
    main()
