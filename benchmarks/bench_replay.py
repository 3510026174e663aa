"""Benchmark: `tankcd replay` end to end (whole process) on the sample terrain.

    python benchmarks/bench_replay.py [--rows 100000] [--out benchmarks/results/replay.md]

A wandering trajectory of ROWS rows over the sample battlefield, replayed as a
user would run it (a fresh process, the terrain store read from disk, poses
written to a file): terrain only (no obstacles, no drums), the sample scene
with its obstacles and drums and a moving turret, and matching alone
(`--terrain`) for comparison. Reports rows/s and, from `--summary`, the share
of time per effect.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLE = os.path.join(os.path.dirname(HERE), "sample_data")


def random_walk(rows, seed=3):
    """A wandering drive over the sample battlefield: x, y (m) and heading (rad), (rows,) each."""
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0, 0.02, rows))
    x = 500120 + np.cumsum(0.5 * np.cos(heading))
    y = 4500080 + np.cumsum(0.5 * np.sin(heading))
    # keep it on the terrain: fold the walk back into the battlefield
    x = 500005 + np.abs((x - 500005) % 460 - 230)
    y = 4500005 + np.abs((y - 4500005) % 300 - 150)
    return x, y, heading


def trajectory(path, rows, seed=3):
    x, y, heading = random_walk(rows, seed)
    t = np.arange(rows) * 0.1
    turret = (t * 12.0) % 360 - 180
    gun = -6 + 8 * (0.5 + 0.5 * np.sin(t / 7))
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg,turret_deg,gun_deg\n")
        np.savetxt(fh, np.column_stack([t, x, y, np.degrees(heading), turret, gun]), fmt="%.3f", delimiter=",")


def once(args):
    """One fresh process: seconds, peak resident memory (MB) and its --summary."""
    with tempfile.TemporaryFile("w+") as err:
        s = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "tankcd_cli", *args, "--summary"], stdout=subprocess.DEVNULL,
                                stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - s
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        text = err.read()
    if proc.returncode not in (0, 1):
        raise SystemExit(text)
    return seconds, usage.ru_maxrss / 1024, json.loads(text.strip().splitlines()[-1])


def run(args, repeats=3):
    times, peaks, summary = [], [], None
    for _ in range(repeats):
        seconds, peak, summary = once(args)
        times.append(seconds)
        peaks.append(peak)
    return float(np.median(times)), min(times), max(times), summary, max(peaks)


def paired(a_args, b_args, repeats=7):
    """Runs of a and b alternated (the honest ratio on a shared machine): medians and the median ratio a / b."""
    ta, tb, pa, pb, sa, sb = [], [], [], [], None, None
    for _ in range(repeats):
        t, p, sa = once(a_args)
        ta.append(t), pa.append(p)
        t, p, sb = once(b_args)
        tb.append(t), pb.append(p)
    return (float(np.median(ta)), max(pa), sa), (float(np.median(tb)), max(pb), sb), \
        float(np.median(np.array(ta) / np.array(tb)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=100_000)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "replay.md"))
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        store = os.path.join(tmp, "battlefield.h5")
        subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", os.path.join(SAMPLE, "battlefield.asc"),
                        "-o", store], check=True)
        traj = os.path.join(tmp, "traj.csv")
        trajectory(traj, a.rows)
        with open(os.path.join(SAMPLE, "scene.toml")) as fh:
            full = fh.read().replace('path = "battlefield.asc"', f'path = "{store}"')
        for name in ("depot.obj", "wall.obj"):
            full = full.replace(f'path = "{name}"', f'path = "{os.path.join(SAMPLE, name)}"')
        with open(os.path.join(tmp, "full.toml"), "w") as fh:
            fh.write(full)
        with open(os.path.join(tmp, "terrain_only.toml"), "w") as fh:
            fh.write(f'[terrain]\npath = "{store}"\n[vehicle]\nfuel_drums = false\n')
        out = os.path.join(tmp, "poses.csv")
        subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "bvh", "--scene", os.path.join(tmp, "full.toml")], check=True)
        cases = [("matching alone (--terrain, an M1: no drums)", ["replay", traj, "--terrain", store, "--vehicle", "m1", "--poses", out]),
                 ("scene, everything off but terrain contact", ["replay", traj, "--scene", os.path.join(tmp, "terrain_only.toml"), "--poses", out]),
                 ("sample scene: obstacles, drums, turret sweep", ["replay", traj, "--scene", os.path.join(tmp, "full.toml"), "--poses", out,
                                                                   "--events", os.path.join(tmp, "e.jsonl")])]
        lines = ["# Benchmark: replay end to end", "",
                 f"{a.rows:,} rows on the sample battlefield, a fresh process each run (start-up, reading, "
                 "matching, effects, writing poses); medians of 3 (min-max).", "",
                 "| case | seconds | rows/s | peak memory | matching | terrain contact | obstacles | internal | collisions |",
                 "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for name, args in cases:
            med, lo, hi, s, peak = run(args)
            sec = s["seconds_by_effect"]
            lines.append(f"| {name} | {med:.2f} ({lo:.2f}-{hi:.2f}) | {a.rows / med:,.0f} | {peak:,.0f} MB | "
                         f"{sec['matching']:.2f} s | {sec['terrain']:.2f} s | {sec['obstacles']:.2f} s | "
                         f"{sec['internal']:.2f} s | {sum(s['collisions'].values()):,} |")
        only = ["replay", traj, "--scene", os.path.join(tmp, "terrain_only.toml"), "--poses", out]
        (te, pe, se), (tp, pp, sp), ratio = paired(only, only + ["--no-escalate"])
        share = 1 - sum(c for m, c in se["matchers"].items() if "+" not in m) / a.rows
        lines += ["", "## What auto's escalation costs", "",
                  "The terrain-only scene, `auto` (escalating: every key-point pose checked against the "
                  "reference's certificate, those that fail solved by the reference) against `auto "
                  "--no-escalate`, runs alternated, medians of 7.", "",
                  "| auto | seconds | rows/s | peak memory | matching | escalated rows |", "| --- | --- | --- | --- | --- | --- |",
                  f"| escalating (default) | {te:.3f} | {a.rows / te:,.0f} | {pe:,.0f} MB | "
                  f"{se['seconds_by_effect']['matching']:.3f} s | {share:.1%} |",
                  f"| --no-escalate | {tp:.3f} | {a.rows / tp:,.0f} | {pp:,.0f} MB | "
                  f"{sp['seconds_by_effect']['matching']:.3f} s | 0 |", "",
                  f"Escalating costs {ratio:.2f}x the plain rule's whole process (the median of the paired ratios); "
                  f"its matching stage alone {se['seconds_by_effect']['matching'] / sp['seconds_by_effect']['matching']:.2f}x."]
    save_report("\n".join(lines + [""]), a.out)


if __name__ == "__main__":
    main()
