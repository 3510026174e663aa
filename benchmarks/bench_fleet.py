"""Benchmark: a fleet of trajectories through `tankcd replay --out-dir`, one process, forked workers, Dask.

    pip install ".[dask]"
    python benchmarks/bench_fleet.py [--trajectories 200] [--rows 10000] [--out benchmarks/results/fleet.md]

The sample scene (obstacles, drums, a sweeping turret) and TRAJECTORIES
wandering trajectories of ROWS rows each, replayed as a user would (a fresh
`tankcd` process each time, start-up included): `--jobs 1`, `--jobs 2`, and
`--scheduler` on a local Dask cluster of two single-threaded worker processes
started beforehand (as a cluster would be). Reports rows/s, the parallel
efficiency (speed-up over --jobs 1 divided by the workers) and the overhead
per task (wall time x workers - time spent inside tasks, per task). Note that
`--jobs 1` already runs its compiled kernels on every core; more processes add
concurrency only for the serial parts (reading, writing, Python between kernels).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLE = os.path.join(os.path.dirname(HERE), "sample_data")


def trajectories(folder, count, rows):
    rng = np.random.default_rng(11)
    for k in range(count):
        heading = np.cumsum(rng.normal(0, 0.02, rows))
        x = 500_005 + np.abs((500_005 + rng.uniform(0, 230) + np.cumsum(0.5 * np.cos(heading)) - 500_005) % 460 - 230)
        y = 4_500_005 + np.abs((4_500_005 + rng.uniform(0, 150) + np.cumsum(0.5 * np.sin(heading)) - 4_500_005) % 300 - 150)
        t = np.arange(rows) * 0.1
        with open(os.path.join(folder, f"run{k:04d}.csv"), "w") as fh:
            fh.write("t,x,y,yaw_deg,turret_deg,gun_deg\n")
            np.savetxt(fh, np.column_stack([t, x, y, np.degrees(heading), (t * 12) % 360 - 180,
                                            -6 + 8 * (0.5 + 0.5 * np.sin(t / 7))]), fmt="%.3f", delimiter=",")


def fleet(args, out):
    if os.path.exists(out):
        shutil.rmtree(out)
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "replay", *args, "--out-dir", out],
                          capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode not in (0, 1):
        raise SystemExit(proc.stderr)
    with open(os.path.join(out, "fleet.json")) as fh:
        summary = json.load(fh)
    return wall, summary


def sample_world(tmp):
    """The sample scene in ``tmp``, its terrain classified beforehand (the store, not the .asc, in the
    scene: no run classifies it again). Returns the scene's path."""
    for name in ("battlefield.asc", "depot.obj", "wall.obj", "scene.toml"):
        shutil.copy(os.path.join(SAMPLE, name), os.path.join(tmp, name))
    subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", os.path.join(tmp, "battlefield.asc"),
                    "-o", os.path.join(tmp, "battlefield.h5")], check=True)
    scene = os.path.join(tmp, "scene.toml")
    with open(scene) as fh:
        text = fh.read().replace("battlefield.asc", "battlefield.h5")
    with open(scene, "w") as fh:
        fh.write(text)
    return scene


def start_cluster(tmp, workers):
    info = os.path.join(tmp, "scheduler.json")
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file", info],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)]
    while not (os.path.exists(info) and os.path.getsize(info)):
        time.sleep(0.1)
    for _ in range(workers):
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", info,
                                       "--nthreads", "1", "--no-dashboard"], stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL, start_new_session=True))
    with open(info) as fh:
        address = json.load(fh)["address"]
    from distributed import Client

    with Client(address) as client:
        client.wait_for_workers(workers, timeout=60)
    return address, procs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trajectories", type=int, default=200)
    ap.add_argument("--rows", type=int, default=10_000)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "fleet.md"))
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scene = sample_world(tmp)
        runs = os.path.join(tmp, "runs")
        os.mkdir(runs)
        trajectories(runs, a.trajectories, a.rows)
        common = [os.path.join(runs, "*.csv"), "--scene", scene]
        cases = []
        for jobs in (1, 2):
            wall, s = fleet(common + ["--jobs", str(jobs)], os.path.join(tmp, f"out{jobs}"))
            cases.append((f"--jobs {jobs}", jobs, wall, s))
        address, procs = start_cluster(tmp, 2)
        try:
            wall, s = fleet(common + ["--scheduler", address], os.path.join(tmp, "outd"))
            cases.append(("--scheduler (local Dask, 2 workers x 1 thread)", 2, wall, s))
            tiny = os.path.join(tmp, "tiny")
            os.mkdir(tiny)
            trajectories(tiny, a.trajectories, 10)
            tiny_wall, tiny_s = fleet([os.path.join(tiny, "*.csv"), "--scene", scene, "--scheduler", address],
                                      os.path.join(tmp, "outt"))
            tiny_local, tiny_l = fleet([os.path.join(tiny, "*.csv"), "--scene", scene, "--jobs", "2"],
                                       os.path.join(tmp, "outtl"))
        finally:
            for p in procs:
                os.killpg(p.pid, signal.SIGTERM)
        same = all(open(os.path.join(tmp, "out1", f), "rb").read() == open(os.path.join(tmp, d, f), "rb").read()
                   for d in ("out2", "outd") for f in os.listdir(os.path.join(tmp, "out1")) if f.endswith(".csv"))

    rows = a.trajectories * a.rows
    base = cases[0][2]
    lines = ["# Benchmark: fleets of trajectories", "",
             f"{a.trajectories} trajectories of {a.rows:,} rows ({rows:,} rows) through the sample scene (obstacles, "
             "drums, a sweeping turret), a fresh `tankcd replay --out-dir` process per case, start-up included; "
             f"one run each. {os.cpu_count()} cores.", "",
             "| case | workers | seconds | rows/s | speed-up | parallel efficiency | overhead per task |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for label, workers, wall, s in cases:
        inside = sum(r["task_seconds"] for r in s["results"])
        overhead = (wall * workers - inside) / a.trajectories
        lines.append(f"| {label} | {workers} | {wall:.2f} | {rows / wall:,.0f} | {base / wall:.2f}x | "
                     f"{base / wall / workers:.0%} | {overhead * 1000:.1f} ms |")
    per_task = (tiny_wall - tiny_local) / a.trajectories
    lines += ["", f"Outputs identical across the three: {same}.", "",
              f"Dask's own cost per task, from {a.trajectories} trajectories of 10 rows: {tiny_wall:.2f} s on the "
              f"cluster against {tiny_local:.2f} s with `--jobs 2`: {per_task * 1000:+.1f} ms per task (the client's "
              "connection, scheduling and shipping results; both load the world once per worker)."]
    text = "\n".join(lines) + "\n"
    print(text)
    save_report(text, a.out)


if __name__ == "__main__":
    main()
