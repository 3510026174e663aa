"""Benchmark: the broad phase over an exercise, sort-and-sweep and the uniform grid against brute force.

    python benchmarks/bench_broad_phase.py [--quick] [--out benchmarks/results/broad_phase.md]

One run, the same segments for every method. An exercise is N vehicles (boxes of 7 m x 3.5 m x
2.2 m) driving for 10 s, each row at 10 Hz starting a rigid segment: 100 segments per vehicle,
M = 100 N. Each segment's box is the vehicle's box at the segment's middle (turned with the
heading) grown by half its motion bound (travel plus turn times the vehicle's radius), over a
gently rolling ground, as the continuous check builds them. Two layouts:

- spread: vehicles anywhere on a 10 km x 10 km area, each its own heading and speed (3-12 m/s);
- platoons: platoons of 10 (two columns of 5, 12 m nose to nose, 8 m apart), every platoon in
  one 1 km x 1 km assembly area of the 10 km area, each platoon its own heading and speed: a
  crowded exercise, with real contacts between platoons.

Every method's pairs are checked equal to brute force where brute force runs, and to each
other everywhere. Times are medians of 3 runs (min-max); peak memory is the largest traced
allocation above the inputs during one further run (tracemalloc, which numpy reports to),
the output included. Brute force runs where its estimated time (from its rate on the smaller
sizes) is under --brute-limit seconds.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
import timeit
import tracemalloc

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))

LENGTH, WIDTH, HEIGHT = 7.0, 3.5, 2.2
RADIUS = float(np.sqrt((LENGTH / 2) ** 2 + (WIDTH / 2) ** 2 + (HEIGHT / 2) ** 2))
AREA = 10_000.0
ASSEMBLY = 1_000.0
RATE, DURATION = 10.0, 10.0


def _ground(x, y):
    return 40.0 * np.sin(x / 900.0) * np.cos(y / 700.0)


def exercise(n: int, layout: str, seed: int = 0, segments: int = int(RATE * DURATION)):
    """(lo (M, 3), hi (M, 3), t0 (M,), t1 (M,), owner (M,)) of n vehicles, M = n * segments."""
    rng = np.random.default_rng(seed)
    times = np.arange(segments + 1) / RATE
    if layout == "spread":
        start = rng.uniform(0, AREA, (n, 2))
        heading0 = rng.uniform(-np.pi, np.pi, n)
        speed = rng.uniform(3, 12, n)
        turn = rng.normal(0, 0.03, n)                      # rad/s
    elif layout == "platoons":
        platoons = -(-n // 10)
        centre = (AREA - ASSEMBLY) / 2 + rng.uniform(0, ASSEMBLY, (platoons, 2))
        h = rng.uniform(-np.pi, np.pi, platoons)
        k = np.arange(n) % 10
        p = np.arange(n) // 10
        along, across = 12.0 * (k % 5 - 2), 8.0 * (k // 5 - 0.5)
        start = centre[p] + np.column_stack([along * np.cos(h[p]) - across * np.sin(h[p]),
                                             along * np.sin(h[p]) + across * np.cos(h[p])])
        heading0 = h[p]
        speed = rng.uniform(3, 12, platoons)[p]
        turn = np.zeros(n)
    else:
        raise ValueError(layout)
    heading = heading0[:, None] + turn[:, None] * times[None, :]          # (n, S + 1)
    # positions by integrating the heading (a straight line when the turn rate is 0)
    step = speed[:, None] / RATE
    dx = np.cumsum(np.c_[np.zeros(n), step * np.cos(0.5 * (heading[:, 1:] + heading[:, :-1]))], axis=1)
    dy = np.cumsum(np.c_[np.zeros(n), step * np.sin(0.5 * (heading[:, 1:] + heading[:, :-1]))], axis=1)
    x, y = start[:, :1] + dx, start[:, 1:] + dy
    xm, ym = 0.5 * (x[:, 1:] + x[:, :-1]), 0.5 * (y[:, 1:] + y[:, :-1])
    hm = 0.5 * (heading[:, 1:] + heading[:, :-1])
    travel = np.hypot(x[:, 1:] - x[:, :-1], y[:, 1:] - y[:, :-1])
    bound = travel + np.abs(heading[:, 1:] - heading[:, :-1]) * RADIUS
    c, s = np.abs(np.cos(hm)), np.abs(np.sin(hm))
    half_x = c * LENGTH / 2 + s * WIDTH / 2 + 0.5 * bound
    half_y = s * LENGTH / 2 + c * WIDTH / 2 + 0.5 * bound
    z = _ground(xm, ym)
    lo = np.stack([xm - half_x, ym - half_y, z - 0.5 * bound - 0.3], axis=-1).reshape(-1, 3)
    hi = np.stack([xm + half_x, ym + half_y, z + HEIGHT + 0.5 * bound + 0.3], axis=-1).reshape(-1, 3)
    t0 = np.broadcast_to(times[:-1], (n, segments)).reshape(-1).copy()
    t1 = np.broadcast_to(times[1:], (n, segments)).reshape(-1).copy()
    owner = np.repeat(np.arange(n, dtype=np.int64), segments)
    return lo, hi, t0, t1, owner


def timed(fn, repeats=3, long=5.0):
    """(result, median s, min s, max s, runs): one run alone when it takes more than ``long`` s,
    else a warm-up and ``repeats`` runs."""
    s = time.perf_counter()
    out = fn()
    first = time.perf_counter() - s
    if first > long:
        return out, first, first, first, 1
    ts = []
    for _ in range(repeats):
        s = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - s)
    return out, float(np.median(ts)), min(ts), max(ts), repeats


def best_of(fn, repeats=5):
    """The least time of one call (s), over ``repeats`` batches of as many calls as fill 0.2 s."""
    timer = timeit.Timer(fn)
    number, _ = timer.autorange()
    return min(timer.repeat(repeats, number)) / number


def peak_memory(fn) -> int:
    """Bytes: the largest traced allocation above the start during one call, its result included."""
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    out = fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    del out
    return peak - base


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="N = 10, 100 and 1000 only, one run each, no cell table")
    ap.add_argument("--brute-limit", type=float, default=200.0,
                    help="s: brute force runs where its estimate (from its rate on smaller sizes) is below this")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "broad_phase.md"))
    args = ap.parse_args()
    from tankcd_cli.collision.broad_phase import (
        AXES,
        BRUTE_FORCE_BELOW,
        GRID_SCALE,
        SWEEP_CANDIDATES_PER_SEGMENT,
        brute_force,
        candidate_pairs,
        chosen_method,
        grid_cell_size,
        projected_overlaps,
        sort_and_sweep,
        uniform_grid,
    )

    repeats = 1 if args.quick else 3
    sizes = (10, 100, 1000) if args.quick else (10, 100, 1000, 5000)
    methods = [("sort_and_sweep", sort_and_sweep), ("uniform_grid", uniform_grid),
               ("candidate_pairs (auto)", candidate_pairs), ("brute_force", brute_force)]
    command = "python benchmarks/bench_broad_phase.py" + (" --quick" if args.quick else "")
    lines = ["# Benchmark: the broad phase over an exercise", "",
             f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores (shared), Python "
             f"{platform.python_version()}, numpy {np.__version__}. Command: `{command}`.", "",
             f"Vehicles of {LENGTH:g} m x {WIDTH:g} m x {HEIGHT:g} m driving for {DURATION:g} s, a rigid segment "
             f"per {1 / RATE:g} s (100 segments each, M = 100 N), each segment's box the vehicle's at its middle "
             "grown by half its motion bound. Spread: anywhere on 10 km x 10 km, own headings and speeds "
             "(3-12 m/s). Platoons: platoons of 10 (two columns of 5, 12 m nose to nose, 8 m apart), all in one "
             "1 km x 1 km assembly area, each platoon its own heading and speed (crowded, real contacts "
             "between platoons).", "",
             "Times: median of 3 runs after a warm-up (min-max), or one run where one takes over 5 s; "
             "'x brute force' is brute force's time over the method's, in the same run (est.: from brute "
             "force's rate of pairs per second on the smaller size, where it was not run); peak: the largest "
             "traced allocation (tracemalloc) above the start of one further run, the output included "
             "(the inputs are 88 bytes a segment); agrees: the same (P, 2) array as brute force (or, where "
             "brute force did not run, as every other method).", ""]
    rate = {}
    for layout in ("spread", "platoons"):
        lines += [f"## {layout.capitalize()}", "",
                  "| vehicles | segments M | pairs | sweep axis: candidates per segment | method | time s | "
                  "x brute force | peak MB | agrees |",
                  "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for n in sizes:
            seg = exercise(n, layout, seed=n)
            m = len(seg[0])
            counts = projected_overlaps(*seg[:4])
            axis = int(np.argmin(counts))
            results = {}
            for name, fn in methods:
                if name == "brute_force" and layout in rate and m * (m - 1) / 2 / rate[layout] > args.brute_limit:
                    results[name] = None
                    continue
                pairs, med, lo_, hi_, runs = timed(lambda: fn(*seg), repeats)
                mem = peak_memory(lambda: fn(*seg))
                results[name] = (pairs, med, lo_, hi_, runs, mem)
                print(layout, n, name, f"{med:.4f}", flush=True)
                if name == "brute_force":
                    rate[layout] = m * (m - 1) / 2 / med
            truth = results["brute_force"][0] if results["brute_force"] else results["sort_and_sweep"][0]
            estimated = results["brute_force"] is None
            brute = m * (m - 1) / 2 / rate[layout] if estimated else results["brute_force"][1]
            chosen = chosen_method(*seg[:4])
            for k, (name, _) in enumerate(methods):
                lead = (f"| {n:,} | {m:,} | {len(truth):,} | {AXES[axis]}: {counts[axis] / m:,.1f} "
                        if k == 0 else "| | | | ")
                label = name + (f" -> {chosen}" if name.startswith("candidate_pairs") else "")
                if results[name] is None:
                    lines.append(lead + f"| {label} | not run (estimated {brute:,.0f}) | 1.0 | | |")
                    continue
                pairs, med, lo_, hi_, runs, mem = results[name]
                spread_ = f" ({lo_:.4f}-{hi_:.4f})" if runs > 1 else " (1 run)"
                agree = "yes" if np.array_equal(pairs, truth) else "NO"
                lines.append(lead + f"| {label} | {med:.4f}{spread_} | {brute / med:,.1f}"
                             f"{' (est.)' if estimated else ''} | {mem / 1e6:.1f} | {agree} |")
        lines.append("")

    # where the methods cross: small exercises (10 vehicles, fewer segments) up to 50,000 segments
    lines += ["## Crossover", "",
              "Least time of one call (best of 5 batches). 10 vehicles with S segments each (M = 10 S), then "
              "20 to 500 vehicles of 100 segments (brute force up to 10,000 segments). K / M: the sweep's "
              "candidates per segment on its best axis. The rule (`candidate_pairs`): brute force below "
              f"{BRUTE_FORCE_BELOW} segments; else the sweep while K / M <= {SWEEP_CANDIDATES_PER_SEGMENT:g}, "
              "the grid above.", "",
              "| layout | segments M | K / M | brute force ms | sort_and_sweep ms | uniform_grid ms | "
              "sweep / grid | fastest | auto picks | auto ms |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    shapes = [(10, 2), (10, 5), (10, 10), (10, 16), (10, 20), (10, 30), (10, 50), (10, 100), (20, 100),
              (50, 100), (100, 100)] + ([] if args.quick else [(200, 100), (300, 100), (500, 100)])
    summary = []
    for layout in ("spread", "platoons"):
        fastest_by_m = []
        for n, segments in shapes:
            seg = exercise(n, layout, seed=n, segments=segments)
            m = len(seg[0])
            k = projected_overlaps(*seg[:4]).min() / m
            fns = [("sort_and_sweep", sort_and_sweep), ("uniform_grid", uniform_grid)]
            if m <= 10_000:
                fns.insert(0, ("brute_force", brute_force))
            ts = {name: best_of(lambda: fn(*seg)) for name, fn in fns}
            auto = best_of(lambda: candidate_pairs(*seg))
            fastest = min(ts, key=ts.get)
            fastest_by_m.append((m, fastest))
            cells = [f"{ts[x] * 1e3:.3f}" if x in ts else "" for x in ("brute_force", "sort_and_sweep", "uniform_grid")]
            lines.append(f"| {layout} | {m:,} | {k:.1f} | " + " | ".join(cells) +
                         f" | {ts['sort_and_sweep'] / ts['uniform_grid']:.2f} | {fastest} | "
                         f"{chosen_method(*seg[:4])} | {auto * 1e3:.3f} |")
            print(layout, m, flush=True)
        ranges = []
        for m, name in fastest_by_m:
            if ranges and ranges[-1][0] == name:
                ranges[-1][2] = m
            else:
                ranges.append([name, m, m])
        summary.append(f"- {layout}: " + "; ".join(f"{name} fastest at {a:,}" + (f"-{b:,}" if b != a else "") +
                                                   " segments" for name, a, b in ranges))
    lines += ["", "Fastest by size (from the rows above):", ""] + summary + [""]

    if not args.quick:
        # the grid's cells: side and length against the segments' typical size
        lines += ["## The grid's cells", "",
                  "Time of `uniform_grid` (least of 3 runs, s) by cell side (times the median horizontal extent) "
                  "and length (times the median time span; inf: one time cell, a grid over x, y alone); "
                  f"the default is {GRID_SCALE[0]:g}, {GRID_SCALE[1]:g}.", ""]
        scales = [(1, 1), (2, 1), (2, 2), (3, 1), (3, 2), (3, 3), (4, 2), (6, 2), (3, np.inf)]
        lines += ["| layout | vehicles | " + " | ".join(f"{a:g}, {b:g}" for a, b in scales) + " |",
                  "| --- | --- | " + " | ".join("---" for _ in scales) + " |"]
        for layout in ("spread", "platoons"):
            for n in (1000, 5000):
                seg = exercise(n, layout, seed=n)
                side, length = grid_cell_size(seg[0], seg[1], seg[2], seg[3], scale=(1.0, 1.0))
                row = []
                for a, b in scales:
                    run = lambda: uniform_grid(*seg, cell=a * side, time_cell=b * length)  # noqa: E731
                    run()
                    row.append(min(_once(run) for _ in range(3)))
                best = min(row)
                lines.append(f"| {layout} | {n:,} | " + " | ".join(
                    f"**{t:.3f}**" if t == best else f"{t:.3f}" for t in row) + " |")
                print(layout, n, "cells", flush=True)
        lines.append("")
    save_report("\n".join(lines), args.out)


def _once(fn):
    s = time.perf_counter()
    fn()
    return time.perf_counter() - s


if __name__ == "__main__":
    main()
