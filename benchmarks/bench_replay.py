"""Benchmark: `tankcd replay` end to end (whole process) on the sample terrain.

    python benchmarks/bench_replay.py [--rows 100000] [--repeats 7] [--out benchmarks/results/replay.md]

A wandering trajectory of ROWS rows over the sample battlefield, replayed as a
user would run it (a fresh process, the terrain store read from disk, poses
written to a file): terrain only (no obstacles, no drums), the sample scene
with its obstacles and drums and a moving turret, and matching alone
(`--terrain`) for comparison. Reports rows/s and, from `--summary`, the share
of time per effect.

Then what the check along the motion between rows (the default) costs against
`--discrete` (the rows alone), runs alternated, REPEATS pairs, the ratio's
median and range over the pairs: the sample scene with every effect at 10 Hz
(target: at most 1.25x), the same drive logged at 1 Hz (ROWS rows 5 m apart,
reported), and a scene whose obstacles the path never approaches (the drive
held to the west of the battlefield, the depot and the wall moved to its east
end: target at most 1.05x).
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


def random_walk(rows, seed=3, width=230.0):
    """A wandering drive over the sample battlefield: x, y (m) and heading (rad), (rows,) each, 0.5 m a
    row, folded back into x from 500005 to 500005 + width."""
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0, 0.02, rows))
    x = 500120 + np.cumsum(0.5 * np.cos(heading))
    y = 4500080 + np.cumsum(0.5 * np.sin(heading))
    # keep it on the terrain: fold the walk back into the battlefield
    x = 500005 + np.abs((x - 500005) % (2 * width) - width)
    y = 4500005 + np.abs((y - 4500005) % 300 - 150)
    return x, y, heading


def trajectory(path, rows, seed=3, hz=10.0, width=230.0):
    """ROWS rows of the walk (10 rows a second at 0.5 m a row: 5 m/s), logged at ``hz``: every
    (10 / hz)-th row of a walk that many times longer."""
    every = int(round(10.0 / hz))
    x, y, heading = (v[::every] for v in random_walk(rows * every, seed, width))
    t = np.arange(rows) / hz
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
    """Runs of a and b alternated (the honest ratio on a shared machine): medians, peaks and summaries,
    and the ratio a / b pair by pair: (median, lowest, highest)."""
    ta, tb, pa, pb, sa, sb = [], [], [], [], None, None
    for _ in range(repeats):
        t, p, sa = once(a_args)
        ta.append(t), pa.append(p)
        t, p, sb = once(b_args)
        tb.append(t), pb.append(p)
    ratios = np.array(ta) / np.array(tb)
    return (float(np.median(ta)), max(pa), sa), (float(np.median(tb)), max(pb), sb), \
        (float(np.median(ratios)), float(ratios.min()), float(ratios.max()))


def verdict(ratio, target=None):
    """Whether the pairs support a ratio against its target, in words."""
    med, lo, hi = ratio
    said = []
    if target is not None:
        said.append(f"target at most {target:.2f}x: " + ("met" if hi <= target else "**not met**" if lo > target
                                                           else "met by the median" if med <= target else
                                                           "**not met** by the median"))
    if hi / lo > 1.5:
        said.append(f"the pairs range over a factor of {hi / lo:.2f}: too wide to read")
    elif lo <= 1.0 <= hi:
        said.append("the pairs hold 1.0x: this machine cannot tell the two apart")
    return "; ".join(said)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=100_000)
    ap.add_argument("--repeats", type=int, default=7, help="pairs behind each ratio")
    ap.add_argument("--only-between", action="store_true",
                    help="only the check along the motion against --discrete (default --out: between_rows.md)")
    ap.add_argument("--out", default=None, help="default: benchmarks/results/replay.md (between_rows.md with "
                                                "--only-between)")
    a = ap.parse_args()
    if a.out is None:
        a.out = os.path.join(HERE, "results", "between_rows.md" if a.only_between else "replay.md")
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
        subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "bvh", "--scene", os.path.join(tmp, "full.toml")],
                       check=True)
        cases = [("matching alone (--terrain, an M1: no drums)",
                  ["replay", traj, "--terrain", store, "--vehicle", "m1", "--poses", out]),
                 ("scene, everything off but terrain contact",
                  ["replay", traj, "--scene", os.path.join(tmp, "terrain_only.toml"), "--poses", out]),
                 ("sample scene: obstacles, drums, turret sweep",
                  ["replay", traj, "--scene", os.path.join(tmp, "full.toml"), "--poses", out,
                   "--events", os.path.join(tmp, "e.jsonl")])]
        made = (f"`python benchmarks/{' '.join([os.path.basename(sys.argv[0])] + sys.argv[1:])}`, "
                f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores (load average "
                f"{os.getloadavg()[0]:.1f} at the start: the machine is shared).")
        if a.only_between:
            lines = ["# Benchmark: the check along the motion between rows against the rows alone", "", made,
                     "", f"{a.rows:,} rows on the sample battlefield in each case."]
            save_report("\n".join(lines + between_rows(a, tmp, store, full, traj, out) + [""]), a.out)
            return
        lines = ["# Benchmark: replay end to end", "", made, "",
                 f"{a.rows:,} rows on the sample battlefield, a fresh process each run (start-up, reading, "
                 "matching, effects, writing poses, and the check along the motion between rows, the default); "
                 "medians of 3 (min-max).", "",
                 "| case | seconds | rows/s | peak memory | matching | terrain contact | obstacles | internal | "
                 "collisions |",
                 "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for name, args in cases:
            med, lo, hi, s, peak = run(args)
            sec = s["seconds_by_effect"]
            lines.append(f"| {name} | {med:.2f} ({lo:.2f}-{hi:.2f}) | {a.rows / med:,.0f} | {peak:,.0f} MB | "
                         f"{sec['matching']:.2f} s | {sec['terrain']:.2f} s | {sec['obstacles']:.2f} s | "
                         f"{sec['internal']:.2f} s | {sum(s['collisions'].values()):,} |")
        only = ["replay", traj, "--scene", os.path.join(tmp, "terrain_only.toml"), "--poses", out]
        (te, pe, se), (tp, pp, sp), esc = paired(only, only + ["--no-escalate"], a.repeats)
        ratio = esc[0]
        share = 1 - sum(c for m, c in se["matchers"].items() if "+" not in m) / a.rows
        lines += ["", "## What auto's escalation costs", "",
                  "The terrain-only scene, `auto` (escalating: every key-point pose checked against the "
                  "reference's certificate, those that fail solved by the reference) against `auto "
                  f"--no-escalate`, runs alternated, medians of {a.repeats}.", "",
                  "| auto | seconds | rows/s | peak memory | matching | escalated rows |",
                  "| --- | --- | --- | --- | --- | --- |",
                  f"| escalating (default) | {te:.3f} | {a.rows / te:,.0f} | {pe:,.0f} MB | "
                  f"{se['seconds_by_effect']['matching']:.3f} s | {share:.1%} |",
                  f"| --no-escalate | {tp:.3f} | {a.rows / tp:,.0f} | {pp:,.0f} MB | "
                  f"{sp['seconds_by_effect']['matching']:.3f} s | 0 |", "",
                  f"Escalating costs {ratio:.2f}x the plain rule's whole process (the median of the paired ratios; "
                  f"pairs {esc[1]:.2f}-{esc[2]:.2f}x{'; ' + verdict(esc) if verdict(esc) else ''}); its matching "
                  "stage alone "
                  f"{se['seconds_by_effect']['matching'] / sp['seconds_by_effect']['matching']:.2f}x (one run each)."]
        lines += between_rows(a, tmp, store, full, traj, out)
    save_report("\n".join(lines + [""]), a.out)


def between_rows(a, tmp, store, full, traj, out):
    """The section on the check along the motion: continuous against --discrete, pairs alternated."""
    slow = os.path.join(tmp, "traj_1hz.csv")
    trajectory(slow, a.rows, hz=1.0)
    west = os.path.join(tmp, "traj_west.csv")
    trajectory(west, a.rows, width=140.0)  # x from 500005 to 500145
    far = full.replace("position = [500112.0, 4500012.0, 99.5]", "position = [500222.0, 4500030.0, 99.5]")
    far = far.replace("position = [500100.0, 4500077.5, 98.5]", "position = [500225.0, 4500120.0, 98.5]")
    assert far != full and far.count("50022") == 2, "the sample scene's obstacles moved: update the far scene"
    with open(os.path.join(tmp, "far.toml"), "w") as fh:
        fh.write(far)
    subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "bvh", "--scene", os.path.join(tmp, "far.toml")],
                   check=True)
    events = os.path.join(tmp, "e.jsonl")
    cases = [("sample scene, every effect, 10 Hz", traj, "full.toml", 1.25),
             ("sample scene, every effect, 1 Hz (rows 5 m apart)", slow, "full.toml", None),
             ("obstacles the path never approaches (60 m off), every effect, 10 Hz", west, "far.toml", 1.05)]
    lines = ["", "## What the check along the motion costs", "",
             f"Each case replayed along the motion between rows (the default) and with `--discrete` (the rows "
             f"alone), fresh processes alternated, {a.repeats} pairs; seconds are medians, the ratio is "
             "continuous over discrete pair by pair (median, lowest-highest). The walk: 5 m/s, the turret "
             "sweeping at 12 deg/s, the gun nodding; at 1 Hz the same walk keeps every tenth row (the same "
             "number of rows, ten times the time). The far scene: the sample scene with the depot and the "
             "wall moved to the east end of the battlefield (east of x = 500214) and the walk held west of "
             "x = 500145 (60 m and more from both, counting the hull).", "",
             "| case | continuous, s | --discrete, s | continuous / discrete | peak memory (cont. / discr.) | "
             "between rows: s, sub-steps, events | verdict |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for name, path, scene, target in cases:
        common = ["replay", path, "--scene", os.path.join(tmp, scene), "--poses", out, "--events", events]
        (tc, pc, sc), (td, pd, sd), ratio = paired(common, common + ["--discrete"], a.repeats)
        motion = sc.get("motion", {})
        lines.append(f"| {name} | {tc:.2f} | {td:.2f} | {ratio[0]:.3f}x ({ratio[1]:.3f}-{ratio[2]:.3f}x) | "
                     f"{pc:,.0f} / {pd:,.0f} MB | {sc['seconds_by_effect'].get('between', 0):.2f} s, "
                     f"{motion.get('substeps', 0):,}, {sum(sc['between'].values()):,} | "
                     f"{verdict(ratio, target) or 'reported (no target)'} |")
    return lines


if __name__ == "__main__":
    main()
