"""Benchmark: what the conservative gates save, whole processes, gates on against `--no-gates`.

    python benchmarks/bench_gates.py [--rows 200000] [--repeats 3] [--out benchmarks/results/gates.md]

Two made 1 km DEMs (512 x 512 posts at 2 m, heights to the millimetre): the ridged game terrain of
``bench_replay.ridged_dem`` (little planar ground: the gates' worst case) and a sloping plain (3 and
2 percent, a millimetre of roughness: mostly planar ground, their best case); on each a random walk
of ROWS rows at 10 Hz (``bench_replay.dem_walk``), T-72 terrain only, the default replay (``auto``,
escalating, along the motion), with the gates and with `--no-gates`, the two runs alternated
REPEATS times. The poses and events of the two are compared byte for byte (the gates must change
nothing); the summary's ``gates`` gives the share each skipped.
"""

from __future__ import annotations

import argparse
import filecmp
import os
import subprocess
import sys
import tempfile

import numpy as np

from _report import save_report
from bench_replay import dem_walk, once, ridged_dem


def plain_dem(path, posts=512, spacing=2.0, seed=11):
    """A sloping plain (3 percent east, 2 percent south) with a millimetre of roughness, written to
    the millimetre as ESRI ASCII; returns its south-west post's x, y and side (m)."""
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:posts, 0:posts]
    z = 50.0 + 0.03 * c * spacing + 0.02 * r * spacing + 0.001 * rng.standard_normal((posts, posts))
    x0, y0 = 300000.0, 5000000.0
    with open(path, "w") as fh:
        fh.write(f"ncols {posts}\nnrows {posts}\nxllcenter {x0}\nyllcenter {y0}\ncellsize {spacing}\n"
                 "NODATA_value -9999\n")
        np.savetxt(fh, z, fmt="%.3f")
    return x0, y0, (posts - 1) * spacing


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=200_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", "gates.md"))
    a = ap.parse_args()
    lines = ["# Benchmark: the conservative gates, on and off", "",
             f"`python benchmarks/bench_gates.py --rows {a.rows} --repeats {a.repeats}`: whole processes, the "
             "default replay with the gates and with `--no-gates`, alternated; medians, ratios the median of "
             f"the {a.repeats} pairs' (smallest-largest). Load before the runs: `{os.getloadavg()[0]:.2f}`.", "",
             "| terrain | gates | seconds | peak memory | matching | between rows | certificate skipped | "
             "poses and events |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    notes = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, make in (("ridged game terrain", ridged_dem), ("sloping plain", plain_dem)):
            dem = os.path.join(tmp, "dem.asc")
            x0, y0, size = make(dem)
            store = os.path.join(tmp, "dem.h5")
            subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", dem, "-o", store], check=True)
            traj = os.path.join(tmp, "walk.csv")
            dem_walk(traj, a.rows, x0, y0, size)
            scene = os.path.join(tmp, "scene.toml")
            with open(scene, "w") as fh:
                fh.write(f'[terrain]\npath = "{store}"\n[vehicle]\npreset = "t72"\nfuel_drums = false\n')
            runs = {"on": [], "off": []}
            for _ in range(a.repeats):
                for label, flags in (("on", []), ("off", ["--no-gates"])):
                    out = [os.path.join(tmp, f"{label}.poses.csv"), os.path.join(tmp, f"{label}.events.jsonl")]
                    runs[label].append(once(["replay", traj, "--scene", scene, "--poses", out[0], "--events", out[1],
                                             *flags]))
            same = all(filecmp.cmp(os.path.join(tmp, f"on.{f}"), os.path.join(tmp, f"off.{f}"), shallow=False)
                       for f in ("poses.csv", "events.jsonl"))
            for label in ("on", "off"):
                secs = float(np.median([r[0] for r in runs[label]]))
                mem = float(np.median([r[1] for r in runs[label]]))
                s = runs[label][-1][2]
                skipped = s.get("gates", {}).get("certificate", {}).get("share_skipped", 0.0)
                lines.append(f"| {name} | {label} | {secs:.2f} | {mem:.0f} MB | {s['seconds_by_effect']['matching']:.2f} s "
                             f"| {s['seconds_by_effect'].get('between', 0):.2f} s | {100 * skipped:.1f}% | "
                             f"{'identical' if same else '**differ**'} |")
            ratios = [on[0] / off[0] for on, off in zip(runs["on"], runs["off"])]
            notes.append(f"- {name}: gates on / off {np.median(ratios):.2f}x ({min(ratios):.2f}-{max(ratios):.2f})")
    save_report("\n".join(lines + [""] + notes) + "\n", a.out)


if __name__ == "__main__":
    main()
