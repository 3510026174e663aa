"""Benchmark: an exercise's rows grouped by vehicle against the same rows in time order.

    python benchmarks/bench_row_order.py [--vehicles 200] [--minutes 16.667] [--hz 10]
                                         [--repeat 2] [--out benchmarks/results/row_order.md]

The world and the exercise are ``bench_exercise.py``'s (platoons wandering over a 4 km rolling
terrain, 4 m posts, classified into a store beforehand, not timed; every vehicle its own phase).
Two files of the same rows:

- **time order**: as ``bench_exercise.py`` writes it, the vehicles interleaved, ``t`` rising: the
  checks between vehicles stream, windows closing as the watermark passes them;
- **grouped**: the same rows sorted by entity (``sort -s -t, -k2,2``: each vehicle's rows together,
  in their order), as per-vehicle loggers write them: the first pass over the times finds them out
  of time order, so the vehicles' segments are spilled to a temporary file by time bucket and
  checked in time order once the trajectory has ended.

Each run is a fresh ``tankcd replay`` process (start-up and the first pass included), the two files
alternating; wall time and peak memory (the child's ``ru_maxrss``); the events compared (every
field but the step numbers, which count each file's own rows).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from _report import save_report
from bench_exercise import run, write_exercise, write_terrain

HERE = os.path.dirname(os.path.abspath(__file__))
STEPS = ("step", "a_step", "b_step")


def group_by_vehicle(path: str, out: str) -> None:
    """``path``'s rows sorted by entity (stable: each vehicle's rows in their order), header first."""
    with open(path) as src, open(out, "w") as dst:
        dst.write(src.readline())
    with open(out, "a") as dst:
        rows = subprocess.Popen(["tail", "-n", "+2", path], stdout=subprocess.PIPE)
        subprocess.run(["sort", "-s", "-t,", "-k2,2"], stdin=rows.stdout, stdout=dst, check=True,
                       env={**os.environ, "LC_ALL": "C"})
        rows.stdout.close()
        if rows.wait():
            raise SystemExit(f"tail failed on {path}")


def events_but_steps(path: str) -> list:
    with open(path) as fh:
        return sorted(json.dumps({k: v for k, v in json.loads(line).items() if k not in STEPS}, sort_keys=True)
                      for line in fh)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vehicles", type=int, default=200)
    ap.add_argument("--minutes", type=float, default=16.667)
    ap.add_argument("--hz", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=2, help="pairs of runs (time order, grouped), best of each")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "row_order.md"))
    ap.add_argument("--keep", default=None, help="keep the inputs and outputs in this folder")
    a = ap.parse_args()
    tmp = a.keep or tempfile.mkdtemp(prefix="tankcd-row-order-")
    os.makedirs(tmp, exist_ok=True)
    try:
        terrain = os.path.join(tmp, "terrain.asc")
        store = os.path.join(tmp, "terrain.h5")
        if not os.path.exists(store):
            write_terrain(terrain)
            subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", terrain, "-o", store], check=True)
        start = time.perf_counter()
        timed, rows = write_exercise(tmp, a.vehicles, a.minutes, a.hz, separate=False)
        grouped = os.path.join(tmp, "grouped.csv")
        group_by_vehicle(timed, grouped)
        made = time.perf_counter() - start

        def args(name, path):
            return ["-q", "replay", path, "--terrain", store, "--poses", os.path.join(tmp, f"{name}.poses.csv"),
                    "--events", os.path.join(tmp, f"{name}.events.jsonl"),
                    "--summary", os.path.join(tmp, f"{name}.summary.json")]

        runs = {"timed": [], "grouped": []}
        loads = []
        for _ in range(a.repeat):
            for name, path in (("timed", timed), ("grouped", grouped)):
                loads.append(os.getloadavg()[0])
                runs[name].append(run(args(name, path)))
        summary = {}
        for name in runs:
            with open(os.path.join(tmp, f"{name}.summary.json")) as fh:
                summary[name] = json.load(fh)
        same = events_but_steps(os.path.join(tmp, "timed.events.jsonl")) == \
            events_but_steps(os.path.join(tmp, "grouped.events.jsonl"))
        best = {name: min(r[0] for r in rs) for name, rs in runs.items()}
        peak = {name: max(r[1] for r in rs) for name, rs in runs.items()}
        ratios = [g[0] / t[0] for t, g in zip(runs["timed"], runs["grouped"])]
        lines = [
            "# Benchmark: an exercise's rows grouped by vehicle against the same rows in time order",
            "",
            f"Machine: {platform.machine()}, {os.cpu_count()} cores (shared), Python {platform.python_version()}, "
            f"numpy {np.__version__}. Command: `nice python benchmarks/bench_row_order.py --vehicles {a.vehicles} "
            f"--minutes {a.minutes:g} --hz {a.hz:g} --repeat {a.repeat}`.",
            "",
            f"{a.vehicles:,} vehicles (bench_exercise.py's platoons) for {a.minutes:g} min at {a.hz:g} Hz: {rows:,} "
            f"rows (both files written in {made:.0f} s, not timed); the grouped file is the same rows sorted by "
            "entity (`sort -s -t, -k2,2`). Each measure a fresh `tankcd -q replay FILE --terrain STORE --poses "
            "--events --summary` process, start-up included; the two files alternate, "
            f"{a.repeat} times; best wall time of each, largest peak memory, and the ratio of each pair. Load "
            f"average (1 min) at the runs' starts: {', '.join(f'{v:.1f}' for v in loads)}.",
            "",
            "| file | wall s | rows/s | peak MB | contacts between vehicles | vehicles s |",
            "| --- | --- | --- | --- | --- | --- |",
        ]
        for name, label in (("timed", "in time order"), ("grouped", "grouped by vehicle")):
            s = summary[name]
            lines.append(f"| {label} | {best[name]:.1f} | {s['rows'] / best[name]:,.0f} | {peak[name]:.0f} | "
                         f"{s['vehicle_contacts']:,} | {s['seconds_by_effect'].get('vehicles', 0):.1f} |")
        lines += [
            "",
            f"Grouped over time order: {', '.join(f'{r:.2f}x' for r in ratios)} in wall time; peak memory "
            f"{peak['grouped'] / peak['timed']:.2f}x. The events are the same (every field but the steps): "
            f"{'yes' if same else 'NO'}.",
        ]
        save_report("\n".join(lines) + "\n", a.out)
    finally:
        if not a.keep:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
