"""Benchmark: an exercise of many vehicles in one world against the same rows as separate trajectories.

    python benchmarks/bench_exercise.py [--vehicles 1000] [--minutes 5] [--hz 2]
                                        [--long-minutes 60 --long-hz 10 --long-vehicles N]
                                        [--out benchmarks/results/exercise.md]

The world: a rolling terrain of 4 km x 4 km with posts 4 m apart (classified once into a store
beforehand, not timed), the T-72 of the default vehicle. The exercise: VEHICLES vehicles in
platoons of four abreast (12 m apart), each platoon wandering at 4-7 m/s with its own heading
noise and steered back when it strays more than 1.2 km from the centre, so that platoons cross
one another and some vehicles meet; every vehicle sends its rows at HZ with its own phase
(asynchronous updates, as DIS entities do), the file in time order.

Measured in the same run, each a fresh ``tankcd`` process (start-up included), one after the other:

- **exercise**: ``tankcd replay exercise.csv`` (one file, an ``entity`` column): every vehicle
  placed, checked against the terrain along its motion, and every two vehicles against each other;
- **separate**: ``tankcd replay runs/*.csv --out-dir D --jobs 1``: the same rows as one file per
  vehicle, each a lone replay in the same process (no contacts between vehicles: that is what the
  exercise adds).

The ratio is exercise over separate. Peak memory is each process's largest resident set
(``ru_maxrss`` of the child). With ``--long-minutes`` the exercise is replayed again over that
many minutes at ``--long-hz`` (with ``--long-vehicles`` vehicles; its file written in blocks, never
held in memory), to show that
time grows with the rows and memory does not.

With ``--gates`` the exercise alone is replayed with the gates and with ``--no-gates``, alternated
``--repeat`` times (no separate trajectories): the walls, the ratio of each pair, the peak memory,
the time in the checks between vehicles and the ``vehicle_pairs`` gate's tally, the outputs
compared byte for byte; the section is appended to ``--out`` (default results/gates.md).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))

SIZE = 4000.0  # m, the terrain's side
POST = 4.0  # m
X0, Y0 = 500_000.0, 4_400_000.0
PLATOON, ABREAST = 4, 12.0


def write_terrain(path: str) -> None:
    n = int(SIZE / POST) + 1
    x = np.arange(n) * POST
    y = x[::-1]  # row 0 north
    z = (200 + 25 * np.sin(x[None, :] / 310.0) * np.cos(y[:, None] / 270.0)
         + 4 * np.sin(x[None, :] / 37.0 + y[:, None] / 53.0))
    with open(path, "w") as fh:
        fh.write(f"ncols {n}\nnrows {n}\nxllcenter {X0}\nyllcenter {Y0}\ncellsize {POST}\n")
        np.savetxt(fh, z, fmt="%.3f")


class Exercise:
    """Platoons wandering over the terrain; rows are produced step by step (memory: the vehicles)."""

    def __init__(self, vehicles: int, hz: float, seed: int = 5):
        rng = self.rng = np.random.default_rng(seed)
        self.n, self.hz = vehicles, hz
        platoons = -(-vehicles // PLATOON)
        self.platoon = np.arange(vehicles) // PLATOON
        self.slot = (np.arange(vehicles) % PLATOON - (PLATOON - 1) / 2) * ABREAST
        self.centre = np.column_stack([X0 + SIZE / 2 + rng.uniform(-1000, 1000, platoons),
                                       Y0 + SIZE / 2 + rng.uniform(-1000, 1000, platoons)])
        self.heading = rng.uniform(-np.pi, np.pi, platoons)
        self.speed = rng.uniform(4, 7, platoons)
        self.phase = rng.uniform(0, 1 / hz, vehicles)
        self.order = np.argsort(self.phase, kind="stable")  # the file in time order
        self.names = np.array([f"P{p:03d}-{s}" for p, s in zip(self.platoon, np.arange(vehicles) % PLATOON)])

    def step(self, k: int):
        """Step k's rows: (t, x, y, yaw_deg) per vehicle in time order, then the platoons move."""
        dt = 1 / self.hz
        h = self.heading[self.platoon]
        # a platoon is abreast: each vehicle offset to the left of the platoon's centre line
        x = self.centre[self.platoon, 0] - np.sin(h) * self.slot
        y = self.centre[self.platoon, 1] + np.cos(h) * self.slot
        t = k * dt + self.phase
        # the phase moves each vehicle along for its own time
        x = x + np.cos(h) * self.speed[self.platoon] * self.phase
        y = y + np.sin(h) * self.speed[self.platoon] * self.phase
        rows = (t[self.order], x[self.order], y[self.order], np.degrees(h)[self.order], self.order)
        away = self.centre - [X0 + SIZE / 2, Y0 + SIZE / 2]
        far = np.hypot(*away.T) > 1200
        home = np.arctan2(-away[:, 1], -away[:, 0])
        turn = np.angle(np.exp(1j * (home - self.heading)))
        rate = self.rng.normal(0, np.radians(3), len(self.heading)) + np.where(far, np.clip(turn, -0.1, 0.1), 0)
        self.heading = self.heading + rate * dt
        self.centre += np.column_stack([np.cos(self.heading), np.sin(self.heading)]) * (self.speed * dt)[:, None]
        return rows


def write_exercise(folder: str, vehicles: int, minutes: float, hz: float, separate: bool) -> tuple[str, int]:
    """exercise.csv (and runs/NAME.csv per vehicle when ``separate``); returns (path, rows)."""
    ex = Exercise(vehicles, hz)
    steps = int(minutes * 60 * hz)
    path = os.path.join(folder, "exercise.csv")
    runs = []
    if separate:
        os.makedirs(os.path.join(folder, "runs"), exist_ok=True)
        runs = [open(os.path.join(folder, "runs", f"{name}.csv"), "w") for name in ex.names]
        for fh in runs:
            fh.write("t,x,y,yaw_deg\n")
    block = max(1, 200_000 // vehicles)
    with open(path, "w") as fh:
        fh.write("t,entity,x,y,yaw_deg\n")
        for k0 in range(0, steps, block):
            parts = [ex.step(k) for k in range(k0, min(steps, k0 + block))]
            t = np.concatenate([p[0] for p in parts])
            x = np.concatenate([p[1] for p in parts])
            y = np.concatenate([p[2] for p in parts])
            yaw = np.concatenate([p[3] for p in parts])
            who = np.concatenate([p[4] for p in parts])
            fh.write("".join(f"{a:.3f},{e},{b:.3f},{c:.3f},{d:.3f}\n"
                             for a, e, b, c, d in zip(t, ex.names[who], x, y, yaw)))
            if separate:
                for v in range(vehicles):
                    sel = who == v
                    runs[v].write("".join(f"{a:.3f},{b:.3f},{c:.3f},{d:.3f}\n"
                                          for a, b, c, d in zip(t[sel], x[sel], y[sel], yaw[sel])))
    for f in runs:
        f.close()
    return path, steps * vehicles


def run(args: list) -> tuple[float, float, str]:
    """A fresh tankcd process: (wall s, peak resident MiB (ru_maxrss is in KiB), stderr)."""
    probe = ("import resource, subprocess, sys, time; s = time.perf_counter(); "
             "p = subprocess.run(sys.argv[1:], capture_output=True, text=True); w = time.perf_counter() - s; "
             "sys.stderr.write(p.stderr); "
             "print(p.returncode, w, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    proc = subprocess.run([sys.executable, "-c", probe, sys.executable, "-m", "tankcd_cli", *args],
                          capture_output=True, text=True)
    code, wall, rss = proc.stdout.split()
    if int(code) not in (0, 1):
        raise SystemExit(f"tankcd {' '.join(args)} failed:\n{proc.stderr}")
    return float(wall), int(rss) / 1024, proc.stderr


def gates_section(a, tmp: str, store: str) -> None:
    """The exercise replayed with the gates and with --no-gates, alternated; a section appended to a.out."""
    import filecmp

    path, rows = write_exercise(tmp, a.vehicles, a.minutes, a.hz, separate=False)
    load = os.getloadavg()
    runs = {True: [], False: []}
    summaries = {}
    for _ in range(a.repeat):
        for gates in (True, False):
            tag = "on" if gates else "off"
            args = ["-q", "replay", path, "--terrain", store, "--poses", os.path.join(tmp, f"{tag}.poses.csv"),
                    "--events", os.path.join(tmp, f"{tag}.events.jsonl"), "--summary",
                    os.path.join(tmp, f"{tag}.summary.json")] + ([] if gates else ["--no-gates"])
            runs[gates].append(run(args))
            with open(os.path.join(tmp, f"{tag}.summary.json")) as fh:
                summaries[gates] = json.load(fh)
    same = all(filecmp.cmp(os.path.join(tmp, f"on.{n}"), os.path.join(tmp, f"off.{n}"), shallow=False)
               for n in ("poses.csv", "events.jsonl"))
    ratios = sorted(on[0] / off[0] for on, off in zip(runs[True], runs[False]))
    pairs = summaries[True]["gates"].get("vehicle_pairs", {})
    command = (f"nice python benchmarks/bench_exercise.py --gates --vehicles {a.vehicles} --minutes {a.minutes:g} "
               f"--hz {a.hz:g} --repeat {a.repeat}")
    lines = [f"## Pairs of vehicles: {a.vehicles:,} vehicles, {a.minutes:g} min at {a.hz:g} Hz", "",
             f"`{command}`: {rows:,} rows (the exercise of bench_exercise.py: platoons of four abreast, 12 m apart, "
             f"crossing), whole processes, the gates on and `--no-gates` alternated {a.repeat} times; best of each, "
             f"the ratio of each pair. Machine: {platform.machine()}, {os.cpu_count()} cores (shared). Load before "
             f"the runs: `{load[0]:.2f} {load[1]:.2f} {load[2]:.2f}`.", "",
             "| gates | wall s | peak MiB | vehicles s | contacts between vehicles | vehicle_pairs checked | skipped |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for gates in (True, False):
        s = summaries[gates]
        p = s["gates"].get("vehicle_pairs", {})
        lines.append(f"| {'on' if gates else 'off'} | {min(r[0] for r in runs[gates]):.1f} | "
                     f"{max(r[1] for r in runs[gates]):.0f} | {s['seconds_by_effect'].get('vehicles', 0):.1f} | "
                     f"{s['vehicle_contacts']:,} | {p.get('checked', '-')} | {p.get('skipped', '-')} |")
    lines += ["", f"- gates on / off: {', '.join(f'{r:.2f}x' for r in ratios)}; pair-windows proven clear: "
              f"{100 * pairs.get('share_skipped', 0):.1f}%; poses and events {'identical' if same else 'DIFFER'}."]
    text = "\n".join(lines) + "\n"
    print(text)
    old = open(a.out).read().rstrip("\n") + "\n\n" if os.path.exists(a.out) else ""
    with open(a.out, "w") as fh:
        fh.write(old + text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vehicles", type=int, default=1000)
    ap.add_argument("--minutes", type=float, default=5.0)
    ap.add_argument("--hz", type=float, default=2.0)
    ap.add_argument("--long-minutes", type=float, default=None)
    ap.add_argument("--long-hz", type=float, default=10.0)
    ap.add_argument("--long-vehicles", type=int, default=None, help="vehicles of the long run (default: --vehicles)")
    ap.add_argument("--repeat", type=int, default=2, help="pairs of runs (exercise, separate), best of each")
    ap.add_argument("--out", default=None, help="default results/exercise.md (results/gates.md with --gates)")
    ap.add_argument("--gates", action="store_true",
                    help="the exercise with the gates and with --no-gates, alternated; a section appended to --out")
    ap.add_argument("--keep", default=None, help="keep the inputs and outputs in this folder")
    a = ap.parse_args()
    if a.out is None:
        a.out = os.path.join(HERE, "results", "gates.md" if a.gates else "exercise.md")
    tmp = a.keep or tempfile.mkdtemp(prefix="tankcd-exercise-")
    os.makedirs(tmp, exist_ok=True)
    try:
        terrain = os.path.join(tmp, "terrain.asc")
        store = os.path.join(tmp, "terrain.h5")
        if not os.path.exists(store):
            write_terrain(terrain)
            subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", terrain, "-o", store], check=True)
        if a.gates:
            gates_section(a, tmp, store)
            return
        start = time.perf_counter()
        path, rows = write_exercise(tmp, a.vehicles, a.minutes, a.hz, separate=True)
        made = time.perf_counter() - start
        ex_args = ["-q", "replay", path, "--terrain", store, "--poses", os.path.join(tmp, "ex.poses.csv"),
                   "--events", os.path.join(tmp, "ex.events.jsonl"), "--summary", os.path.join(tmp, "ex.summary.json")]
        out = os.path.join(tmp, "separate")
        sep_args = ["-q", "replay", os.path.join(tmp, "runs", "*.csv"), "--terrain", store, "--out-dir", out,
                    "--jobs", "1"]
        ex_runs, sep_runs = [], []
        for _ in range(a.repeat):
            ex_runs.append(run(ex_args))
            shutil.rmtree(out, ignore_errors=True)
            sep_runs.append(run(sep_args))
        with open(os.path.join(tmp, "ex.summary.json")) as fh:
            summary = json.load(fh)
        with open(os.path.join(out, "fleet.json")) as fh:
            fleet = json.load(fh)
        ratios = [e[0] / s[0] for e, s in zip(ex_runs, sep_runs)]
        ex_best = min(ex_runs)
        sep_best = min(sep_runs)
        lines = [
            "# Benchmark: an exercise in one world against separate trajectories",
            "",
            f"Machine: {platform.machine()}, {os.cpu_count()} cores (shared), Python {platform.python_version()}, "
            f"numpy {np.__version__}. Command: `python benchmarks/bench_exercise.py --vehicles {a.vehicles} "
            f"--minutes {a.minutes:g} --hz {a.hz:g}"
            + (f" --long-minutes {a.long_minutes:g} --long-hz {a.long_hz:g}" if a.long_minutes else "")
            + (f" --long-vehicles {a.long_vehicles}" if a.long_vehicles else "") + "`.",
            "",
            f"{a.vehicles:,} vehicles (T-72s, platoons of {PLATOON} abreast) for {a.minutes:g} min at {a.hz:g} Hz, "
            f"each its own phase: {rows:,} rows (written in {made:.0f} s, not timed); a terrain of 4 km x 4 km, "
            "4 m posts, classified beforehand. Each measure a fresh process, start-up included; the two "
            f"commands alternate, {a.repeat} times; best of each, and the ratio of each pair.",
            "",
            "| command | rows | wall s | rows/s | peak MiB | contacts between vehicles |",
            "| --- | --- | --- | --- | --- | --- |",
            f"| exercise: `replay exercise.csv` | {summary['rows']:,} | {ex_best[0]:.1f} | "
            f"{summary['rows'] / ex_best[0]:,.0f} | {max(r[1] for r in ex_runs):.0f} | "
            f"{summary['vehicle_contacts']:,} |",
            f"| separate: `replay runs/*.csv --out-dir D --jobs 1` | {fleet['rows']:,} | {sep_best[0]:.1f} | "
            f"{fleet['rows'] / sep_best[0]:,.0f} | {max(r[1] for r in sep_runs):.0f} | (not checked) |",
            "",
            f"Exercise over separate: {', '.join(f'{r:.2f}x' for r in ratios)}, best against best "
            f"{ex_best[0] / sep_best[0]:.2f}x (target: at most 1.25x); peak memory "
            f"{max(r[1] for r in ex_runs):.0f} MiB (target: at most 400 MiB).",
            "",
            "The exercise's summary: " + ", ".join(f"{k} {v}" for k, v in summary["seconds_by_effect"].items())
            + f" s by effect; {summary['motion'].get('intervals', 0):,} intervals, "
            f"{summary['motion'].get('substeps', 0):,} sub-steps.",
        ]
        if a.long_minutes:
            long_vehicles = a.long_vehicles or a.vehicles
            long_dir = os.path.join(tmp, "long")
            os.makedirs(long_dir, exist_ok=True)
            runs = []
            for minutes in (5.0, a.long_minutes):
                lpath, lrows = write_exercise(long_dir, long_vehicles, minutes, a.long_hz, separate=False)
                wall, rss, _ = run(["-q", "replay", lpath, "--terrain", store, "--poses",
                                    os.path.join(long_dir, "p.csv"), "--events", os.path.join(long_dir, "e.jsonl"),
                                    "--summary", os.path.join(long_dir, "s.json")])
                with open(os.path.join(long_dir, "s.json")) as fh:
                    s = json.load(fh)
                runs.append((minutes, lrows, wall, rss, s["vehicle_contacts"]))
                os.remove(lpath)
            lines += ["", f"## Long: {long_vehicles:,} vehicles at {a.long_hz:g} Hz", "",
                      "| minutes | rows | wall s | rows/s | peak MiB | contacts between vehicles |",
                      "| --- | --- | --- | --- | --- | --- |"]
            lines += [f"| {m:g} | {r:,} | {w:.0f} | {r / w:,.0f} | {p:.0f} | {c:,} |" for m, r, w, p, c in runs]
        save_report("\n".join(lines) + "\n", a.out)
    finally:
        if not a.keep:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
