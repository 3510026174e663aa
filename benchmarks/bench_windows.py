"""Benchmark: one exercise through `tankcd replay`, in one piece and by time windows (here and on Dask).

    pip install ".[dask]"
    python benchmarks/bench_windows.py [--vehicles 100] [--seconds 300] [--window 60]
        [--out benchmarks/results/windows.md]

The sample scene (obstacles, drums) and VEHICLES wandering vehicles in one
trajectory file with an entity column, each reporting at 2 Hz for SECONDS,
replayed as a user would (a fresh `tankcd` process each time, start-up
included): in one piece; by `--window-seconds WINDOW` one window after the
other in the one process; and by windows on a local Dask cluster of two
single-threaded worker processes started beforehand. Reports the wall time,
the command's peak memory (its own process; the workers' are their own) and
whether the poses and events are the same bytes as the run in one piece.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile

import numpy as np

from _report import save_report
from bench_fleet import sample_world, start_cluster  # the sample world and the local cluster the fleets use

HERE = os.path.dirname(os.path.abspath(__file__))


def exercise(path, vehicles, seconds, hz=2.0):
    rng = np.random.default_rng(5)
    n = int(seconds * hz)
    t = np.arange(n) / hz
    cols = []
    for v in range(vehicles):
        heading = rng.uniform(-np.pi, np.pi) + np.cumsum(rng.normal(0, 0.05, n))
        speed = rng.uniform(2, 6) / hz
        x = np.abs((rng.uniform(0, 440) + np.cumsum(speed * np.cos(heading))) % 880 - 440) + 500_010
        y = np.abs((rng.uniform(0, 280) + np.cumsum(speed * np.sin(heading))) % 560 - 280) + 4_500_010
        # the heading of the travel itself (the walls fold the path back on itself)
        yaw = np.degrees(np.arctan2(np.gradient(y), np.gradient(x)))
        cols.append((t, np.full(n, v), x, y, yaw))
    t, e, x, y, yaw = (np.concatenate(c) for c in zip(*cols))
    order = np.lexsort((e, t))
    with open(path, "w") as fh:
        fh.write("t,entity,x,y,yaw_deg\n")
        fh.writelines(f"{t[i]:.2f},v{int(e[i]):04d},{x[i]:.3f},{y[i]:.3f},{yaw[i]:.2f}\n" for i in order)
    return len(t)


def replay(args, out):
    os.makedirs(out, exist_ok=True)
    cmd = [sys.executable, "-m", "tankcd_cli", "-q", "replay", *args, "--poses", os.path.join(out, "p.csv"),
           "--events", os.path.join(out, "e.jsonl"), "--summary", os.path.join(out, "s.json")]
    probe = ("import resource, subprocess, sys, time; t = time.perf_counter(); "
             "r = subprocess.run(sys.argv[1:]); w = time.perf_counter() - t; "
             "print(r.returncode, w, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    proc = subprocess.run([sys.executable, "-c", probe, *cmd], capture_output=True, text=True)
    code, wall, rss = proc.stdout.split()
    if int(code) not in (0, 1):
        raise SystemExit(proc.stderr)
    with open(os.path.join(out, "s.json")) as fh:
        summary = json.load(fh)
    return float(wall), int(rss) / 1024, summary


def same(a, b):
    return all(open(os.path.join(a, f), "rb").read() == open(os.path.join(b, f), "rb").read()
               for f in ("p.csv", "e.jsonl"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vehicles", type=int, default=100)
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--window", type=float, default=60.0)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "windows.md"))
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scene = sample_world(tmp)
        path = os.path.join(tmp, "exercise.csv")
        rows = exercise(path, a.vehicles, a.seconds)
        common = [path, "--scene", scene]
        windows = ["--window-seconds", f"{a.window:g}"]
        cases = [("in one piece", *replay(common, os.path.join(tmp, "one")), "one")]
        cases.append((f"--window-seconds {a.window:g}, here", *replay(common + windows, os.path.join(tmp, "here")),
                      "here"))
        address, procs = start_cluster(tmp, 2)
        try:
            cases.append((f"--window-seconds {a.window:g} --scheduler (local Dask, 2 workers x 1 thread)",
                          *replay(common + windows + ["--scheduler", address], os.path.join(tmp, "dask")), "dask"))
        finally:
            for p in procs:
                os.killpg(p.pid, signal.SIGTERM)
        identical = {name: same(os.path.join(tmp, "one"), os.path.join(tmp, name)) for *_, name in cases[1:]}
    base = cases[0][1]
    contacts = cases[0][3]["vehicle_contacts"]
    lines = ["# Benchmark: an exercise by time windows", "",
             f"{a.vehicles} vehicles for {a.seconds:g} s at 2 Hz ({rows:,} rows) in one file through the sample "
             f"scene (obstacles, drums), {contacts} contacts between vehicles; a fresh `tankcd replay` process per "
             f"case, start-up included; one run each. {os.cpu_count()} cores.", "",
             "| case | seconds | rows/s | against one piece | peak memory of the command | same bytes |",
             "| --- | --- | --- | --- | --- | --- |"]
    for label, wall, mb, summary, name in cases:
        lines.append(f"| {label} | {wall:.2f} | {rows / wall:,.0f} | {wall / base:.2f}x | {mb:,.0f} MB | "
                     f"{identical.get(name, '-')} |")
    text = "\n".join(lines) + "\n"
    save_report(text, a.out)


if __name__ == "__main__":
    main()
