"""Benchmark: the ``jet`` mean curvature, the numpy path (cKDTree + ``jet_fit_numpy``) against the compiled one.

    python benchmarks/bench_jet.py [--sizes 100000,1000000] [--repeats 3] [--skip-numpy-1m]
                                   [--out benchmarks/results/jet.md]

Meshes: ``synthetic.jittered_mesh`` (grid points moved by up to a third of the
spacing, Delaunay-triangulated) of a Gaussian hill at UTM-like offsets, about
100k and 1M vertices. The timed call is ``curvature.jet_curvature`` over the
interior vertices with k = 20 (as ``mean_curvature`` makes it); normals and the
open-vertex flags are computed before timing. Each case runs in its own child
process pinned to 1 or 2 cores (``os.sched_setaffinity``; the kernels' threads
set to match, cKDTree's ``workers=-1`` sees the same cores), so its peak RSS
(``getrusage(RUSAGE_SELF).ru_maxrss``) is its own; the peak includes the mesh.
Times are the minimum of ``--repeats`` calls after the first. The largest
|H_compiled - H_numpy| is over every computed vertex.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))

CHILD = r"""
import json, os, resource, sys, time
import numpy as np
cores, path, fast, repeats, out = sys.argv[1:6]
os.sched_setaffinity(0, list(range(int(cores))))
from tankcd_cli.threads import set_num_threads
set_num_threads(int(cores))
from tankcd_cli.terrain.curvature import jet as C
d = np.load(path)
V, normal, which = d["V"], d["normal"], d["which"]
fast = fast == "1"
times = []
for r in range(int(repeats) + 1):
    t = time.perf_counter()
    H = C.jet_curvature(V, normal, which, fast=fast)
    times.append(time.perf_counter() - t)
np.save(out, H)
print(json.dumps({"seconds": min(times[1:]) if len(times) > 1 else times[0],
                  "maxrss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))
"""


def make_mesh(n_target: int, work: str) -> tuple[str, int, int]:
    from tankcd_cli.terrain import synthetic as S
    from tankcd_cli.terrain.curvature.mean import open_vertices, vertex_normals

    side = int(round(np.sqrt(n_target)))
    half = (side - 1) / 2.0
    V, F, _ = S.jittered_mesh(S.gaussian_hill(40.0, side / 4.0), half, 1.0, seed=1,
                              offset=(500_000.0, 4_500_000.0, 100.0))
    normal = vertex_normals(V, F)
    which = ~open_vertices(F, len(V)).mask
    path = os.path.join(work, f"mesh_{len(V)}.npz")
    np.savez(path, V=V, normal=normal, which=which)
    return path, len(V), int(which.sum())


def make_mesh_apart(n_target: int, work: str) -> tuple[str, int, int]:
    """make_mesh in a child process: this one stays small, and the children it starts later inherit
    no large peak (Linux keeps ru_maxrss across exec)."""
    p = subprocess.run([sys.executable, os.path.abspath(__file__), "--make", str(n_target), work],
                       capture_output=True, text=True, cwd=os.path.dirname(HERE))
    if p.returncode:
        raise RuntimeError(p.stderr)
    path, n, m = json.loads(p.stdout.strip().splitlines()[-1])
    return path, n, m


def run(cores: int, path: str, fast: bool, repeats: int, work: str) -> tuple[dict, np.ndarray]:
    out = os.path.join(work, f"H_{cores}_{int(fast)}.npy")
    p = subprocess.run([sys.executable, "-c", CHILD, str(cores), path, "1" if fast else "0", str(repeats), out],
                       capture_output=True, text=True, cwd=os.path.dirname(HERE))
    if p.returncode:
        raise RuntimeError(p.stderr)
    return json.loads(p.stdout.strip().splitlines()[-1]), np.load(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="100000,1000000")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--skip-numpy-1m", action="store_true", help="numpy path only below 1M vertices")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "jet.md"))
    ap.add_argument("--make", nargs=2, metavar=("SIZE", "DIR"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.make:
        print(json.dumps(make_mesh(int(args.make[0]), args.make[1])))
        return
    cores = min(2, len(os.sched_getaffinity(0)))
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for size in [int(s) for s in args.sizes.split(",")]:
            path, n, m = make_mesh_apart(size, work)
            ref = None
            results = {}
            for fast in (False, True):
                if not fast and args.skip_numpy_1m and n >= 1_000_000:
                    continue
                for c in sorted({1, cores}):
                    res, H = run(c, path, fast, 1 if not fast else args.repeats, work)
                    results[fast, c] = res
                    if not fast and ref is None:
                        ref = H
                    diff = float(np.abs(H - ref).max()) if ref is not None else float("nan")
                    rows.append((n, m, "compiled" if fast else "numpy", c, res["seconds"] / m * 1e6,
                                 res["seconds"], res["maxrss_kib"] / 1024, diff, float(np.abs(H).max())))
                    print(rows[-1], flush=True)
    lines = [
        "# jet mean curvature: numpy path vs compiled",
        "",
        f"{datetime.date.today()}, {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, numpy {np.__version__}",
        "",
        "`curvature.jet_curvature` over the interior vertices (k = 20, degree 4) of a jittered Delaunay "
        "mesh at UTM offsets; each case in its own process pinned to the cores shown. "
        "Time: the minimum of the repeats after a first call (the numpy path: one timed call after the first). "
        "Peak RSS (getrusage) includes Python, numpy and the mesh (about 75 MiB at 1M vertices). "
        "max |dH|: against the numpy path on the same mesh "
        "(|H| up to the last column).",
        "",
        "| vertices | computed | path | cores | us/vertex | seconds | peak RSS MiB | max abs dH | max abs H |",
        "|---:|---:|---|---:|---:|---:|---:|---:|---:|",
    ]
    for n, m, name, c, us, sec, mib, diff, hmax in rows:
        lines.append(f"| {n:,} | {m:,} | {name} | {c} | {us:.2f} | {sec:.2f} | {mib:.0f} | {diff:.1e} | {hmax:.2e} |")
    save_report("\n".join(lines) + "\n", args.out)


if __name__ == "__main__":
    main()
