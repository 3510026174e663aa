"""Benchmark: mean curvature and `tankcd classify` against libigl and trimesh, in one run.

    pip install ".[bench]"
    python benchmarks/bench_classify.py [--quick] [--out benchmarks/results/classify.md]

Every measurement runs in its own child process (so peak memory is its own and
imports are not shared), on the same generated grid: a Gaussian hill on
rolling ground at 1 m spacing, whose mean curvature is known in closed form.
Times are medians of repeated runs with the range shown; compare the ratios,
not the seconds: this machine is shared and noisy.

Peers:
- libigl: cotmatrix + Voronoi massmatrix, H = (-M^-1 L V) . n / 2 (the same
  discrete formula as our default; the reference for speed);
- trimesh: discrete_mean_curvature_measure (Cohen-Steiner and Morvan) over a
  ball of radius 2 m, divided by its area pi r^2. It costs tens of
  microseconds per point, so on the large grid it runs on a sample of points
  and its time is reported per vertex and scaled.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))


def surface():
    from tankcd_cli.terrain import synthetic as S

    hill, roll = S.gaussian_hill(6.0, 40.0), S.sinusoid(1.0, 70.0, 55.0)
    return S.HeightField(
        "hill_on_rolling_ground",
        lambda x, y: hill.f(x, y) + roll.f(x, y),
        lambda x, y: tuple(a + b for a, b in zip(hill.grad(x, y), roll.grad(x, y))),
        lambda x, y: tuple(a + b for a, b in zip(hill.hess(x, y), roll.hess(x, y))))


def make_grid(size: int):
    from tankcd_cli.terrain import synthetic as S

    half = (size - 1) / 2.0
    V, F, xy = S.grid_mesh(surface(), half, 1.0, offset=(500_000.0, 4_500_000.0, 100.0))
    return V, F, xy


# --- worker: one method, one size, in a child process --------------------------

def worker(method: str, size: int, repeats: int) -> dict:
    V, F, xy = make_grid(size)
    truth = surface().mean_curvature(xy[:, 0], xy[:, 1])
    half = (size - 1) / 2.0
    interior = np.max(np.abs(xy), axis=1) < half - 3
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    sample = None
    if method.startswith("tankcd-"):
        from tankcd_cli.terrain.curvature.mean import mean_curvature

        name = method.split("-", 1)[1]
        run = lambda: mean_curvature(V, F, name)  # noqa: E731
    elif method == "libigl":
        import igl

        local = V - V.mean(axis=0)  # libigl works on raw numbers: give it small ones

        def run():
            L = igl.cotmatrix(local, F)
            M = igl.massmatrix(local, F, igl.MASSMATRIX_TYPE_VORONOI)
            HN = -(L @ local) / M.diagonal()[:, None]
            N = igl.per_vertex_normals(local, F)
            N[N[:, 2] < 0] *= -1
            return 0.5 * np.einsum("ij,ij->i", HN, N)
    elif method == "trimesh":
        import trimesh

        mesh = trimesh.Trimesh(V - V.mean(axis=0), F, process=False)
        sample = np.arange(len(V)) if len(V) <= 100_000 else np.random.default_rng(0).choice(len(V), 20_000, replace=False)
        radius = 2.0

        def run():
            measure = trimesh.curvature.discrete_mean_curvature_measure(mesh, mesh.vertices[sample], radius)
            out = np.full(len(V), np.nan)
            out[sample] = measure / (np.pi * radius**2)
            return out
    else:
        raise SystemExit(f"unknown method {method}")
    times = []
    H = None
    for _ in range(repeats):
        t = time.perf_counter()
        H = run()
        times.append(time.perf_counter() - t)
    peak_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024.0
    sel = interior if sample is None else interior & np.isin(np.arange(len(V)), sample)
    scale = 0.1 * np.abs(truth[interior]).max()
    rel = np.abs(H[sel] - truth[sel]) / np.maximum(np.abs(truth[sel]), scale)
    per_vertex = np.array(times) / (len(V) if sample is None else len(sample))
    return {"method": method, "size": size, "vertices": len(V), "times": times,
            "per_vertex_s": float(np.median(per_vertex)), "full_s": float(np.median(per_vertex) * len(V)),
            "sampled": sample is not None, "median_rel_err": float(np.median(rel)),
            "p99_rel_err": float(np.percentile(rel, 99)), "peak_extra_mb": peak_mb}


def run_worker(method, size, repeats, env=None):
    proc = subprocess.run([sys.executable, __file__, "--worker", method, str(size), str(repeats)],
                          capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        return {"method": method, "size": size, "error": proc.stderr.strip().splitlines()[-1:]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def write_asc(path, size):
    V, F, xy = make_grid(size)
    Z = V[:, 2].reshape(size, size)[::-1]
    with open(path, "w") as fh:
        fh.write(f"ncols {size}\nnrows {size}\nxllcenter {V[0, 0]:.3f}\nyllcenter {V[0, 1]:.3f}\ncellsize 1\n")
        np.savetxt(fh, Z, fmt="%.3f")


def time_command(args, repeats, env=None):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        proc = subprocess.run(args, capture_output=True, text=True, env=env)
        times.append(time.perf_counter() - t)
        if proc.returncode != 0:
            raise SystemExit(f"{' '.join(args)} failed: {proc.stderr}")
    return times


def fmt_times(times):
    return f"{np.median(times):.3f} ({min(times):.3f}-{max(times):.3f})"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--worker", nargs=3)
    ap.add_argument("--quick", action="store_true", help="300x300 only, fewer repeats")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "classify.md"))
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker[0], int(args.worker[1]), int(args.worker[2]))))
        return

    sizes = [300] if args.quick else [300, 1000]
    methods = ["tankcd-cotan", "tankcd-sphere", "tankcd-jet", "libigl", "trimesh"]
    lines = ["# Benchmark: mean curvature and classify", "",
             f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
             f"Python {platform.python_version()}, numpy {np.__version__}.", ""]
    run_worker("tankcd-cotan", 300, 1)  # warm the file cache once: the table shows steady-state cost
    for size in sizes:
        repeats = 5 if size <= 300 else 3
        rows = [run_worker(m, size, repeats) for m in methods]
        base = next((r for r in rows if r["method"] == "libigl" and "error" not in r), None)
        lines += [f"## Curvature on a {size} x {size} grid ({size * size:,} vertices), seconds: median (min-max) of {repeats}", "",
                  "| method | time | x faster than libigl | per vertex | median rel. error | p99 rel. error | extra peak memory |",
                  "| --- | --- | --- | --- | --- | --- | --- |"]
        for r in rows:
            if "error" in r:
                lines.append(f"| {r['method']} | failed: {r['error']} | | | | | |")
                continue
            ratio = base["full_s"] / r["full_s"] if base else float("nan")
            t = fmt_times(r["times"]) if not r["sampled"] else f"{r['full_s']:.2f} (scaled from a 20 000-point sample)"
            lines.append(f"| {r['method']} | {t} | {ratio:.2f} | {r['per_vertex_s'] * 1e9:.0f} ns | "
                         f"{r['median_rel_err']:.2e} | {r['p99_rel_err']:.2e} | {r['peak_extra_mb']:.0f} MB |")
        lines.append("")

    with tempfile.TemporaryDirectory() as tmp:
        lines += ["## `tankcd classify` end to end (whole process: start-up, read, curvature, classes, write)", "",
                  "| input | time, s | |", "| --- | --- | --- |"]
        for size in sizes:
            path = os.path.join(tmp, f"grid{size}.asc")
            write_asc(path, size)
            cmd = [sys.executable, "-m", "tankcd_cli", "-q", "classify", path, "-o", os.path.join(tmp, "out.h5")]
            lines.append(f"| {size} x {size} ASC grid | {fmt_times(time_command(cmd, 3))} | grid layout, tiled |")
            obj = os.path.join(tmp, f"grid{size}.obj")
            V, F, _ = make_grid(size)
            import trimesh

            trimesh.Trimesh(V, F, process=False).export(obj)
            cmd = [sys.executable, "-m", "tankcd_cli", "-q", "classify", obj, "-o", os.path.join(tmp, "out.h5")]
            lines.append(f"| {size} x {size} OBJ mesh | {fmt_times(time_command(cmd, 3))} | irregular-mesh path: merge, buckets |")
        help_times = time_command([sys.executable, "-m", "tankcd_cli", "--help"], 5)
        lines += ["", f"`tankcd --help`: {fmt_times(help_times)} s.", ""]
    save_report("\n".join(lines), args.out)


if __name__ == "__main__":
    main()
