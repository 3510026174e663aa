"""Benchmark: height queries and matchers on a 1M-vertex terrain, against trimesh's ray caster.

    pip install ".[bench]"
    python benchmarks/bench_matching.py [--quick] [--out benchmarks/results/matching.md]

The terrain is a 1000 x 1000 DEM at 1 m spacing (rolling ground with craters)
at UTM-like coordinates; 100 000 random poses. The peer is what a user would
otherwise write: vertical rays from above the key points, cast with trimesh's
ray caster (the embree backend when embreex is installed), then the same
plane arithmetic. Times are medians of repeats in one process, after one
warm-up call (the compiled kernels' load time is reported separately).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))


def terrain(size: int):
    from tankcd_cli.terrain import synthetic as S

    rng = np.random.default_rng(1)
    xs = np.arange(size, dtype=float)
    X, Y = np.meshgrid(xs, xs)
    Z = 1.5 * np.sin(X / 11.0) * np.cos(Y / 9.0) + 0.02 * X
    for cx, cy in rng.uniform(20, size - 20, (size // 10, 2)):
        r = np.hypot(X - cx, Y - cy)
        Z += np.where(r < 5, -1.5 * (1 - (r / 5) ** 2) ** 2, 0) + 0.4 * np.exp(-((r - 5) / 1.5) ** 2)
    return S.dem_terrain(Z, origin=(500_000.0, 4_500_000.0))


def timed(fn, repeats):
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return np.median(times), min(times), max(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="300 x 300 terrain, 20 000 poses")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "matching.md"))
    args = ap.parse_args()
    size, n, repeats = (300, 20_000, 3) if args.quick else (1000, 100_000, 3)

    from tankcd_cli.matching.match import KEY_POINT_MATCHERS, MATCHERS, match
    from tankcd_cli.terrain.mesh.classify import classify_mesh
    from tankcd_cli.terrain.mesh.surface import MeshSurface
    from tankcd_cli.vehicle import key_points, vehicle_preset, wheel_stations

    raw = terrain(size)
    store = classify_mesh(raw)
    surface = MeshSurface.from_store(store)
    vehicle = vehicle_preset("t72")
    rng = np.random.default_rng(2)
    x = 500_000.0 + rng.uniform(10, size - 10, n)
    y = 4_500_000.0 + rng.uniform(10, size - 10, n)
    yaw = rng.uniform(-np.pi, np.pi, n)


    lines = ["# Benchmark: terrain queries and matchers", "",
             f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
             f"{platform.python_version()}. Terrain {size} x {size} DEM ({size * size:,} vertices, "
             f"{len(store.faces):,} triangles), {n:,} poses, medians of {repeats} (min-max).", "",
             ""]

    # peer: trimesh ray casting of vertical rays
    import trimesh

    local = store.vertices - [500_000.0, 4_500_000.0, 0.0]
    mesh = trimesh.Trimesh(local, store.faces, process=False)
    engine = type(mesh.ray).__module__.split(".")[-1]
    top = store.vertices[:, 2].max() + 10

    def ray_heights(px, py):
        origins = np.column_stack([px - 500_000.0, py - 4_500_000.0, np.full(len(px), top)])
        directions = np.tile([0.0, 0.0, -1.0], (len(px), 1))
        locs, idx, _ = mesh.ray.intersects_location(origins, directions, multiple_hits=False)
        z = np.full(len(px), np.nan)
        z[idx] = locs[:, 2]
        return z

    qx = x.copy()
    qy = y.copy()
    ours = timed(lambda: surface.height_normal(qx, qy), repeats)
    peer = timed(lambda: ray_heights(qx, qy), 1)
    lines += ["## Height and normal at 100 000 points" if not args.quick else "## Height and normal at 20 000 points", "",
              "| method | points/s | ratio |", "| --- | --- | --- |",
              f"| tankcd MeshSurface.height_normal | {n / ours[0]:,.0f} | {peer[0] / ours[0]:.1f}x |",
              f"| trimesh vertical rays ({engine}) | {n / peer[0]:,.0f} | 1.0x |", ""]

    lines += ["## Matchers", "",
              "| matcher | poses/s (pose only) | poses/s (with penetration, gap) | trimesh rays + same plane arithmetic, poses/s | ours / peer |",
              "| --- | --- | --- | --- | --- |"]
    for label in MATCHERS + ("auto --no-escalate", "auto"):
        m, escalate = label.split()[0], None if label == "auto" else False
        pose_only = timed(lambda: match(surface, vehicle, x, y, yaw, m, measure=False, regions=(m == "auto"),
                                        escalate=escalate), repeats)
        measured = timed(lambda: match(surface, vehicle, x, y, yaw, m, measure=True, escalate=escalate),
                         1 if m == "reference" else repeats)
        peer_rate = ""
        ratio = ""
        if m in KEY_POINT_MATCHERS:
            pts = wheel_stations(vehicle) if m == "wheel_stations" else key_points(
                vehicle, {"two_point": 2, "four_point": 4, "six_point": 6}[m])
            if m == "two_point":
                pts = np.vstack([pts, [[0.0, 0.0]]])
            c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
            px = (x[:, None] + c * pts[:, 0] - s * pts[:, 1]).ravel()
            py = (y[:, None] + s * pts[:, 0] + c * pts[:, 1]).ravel()
            peer_t = timed(lambda: ray_heights(px, py), 1)[0]
            peer_rate = f"{n / peer_t:,.0f}"
            ratio = f"{peer_t / pose_only[0]:.1f}x"
        lines.append(f"| {label} | {n / pose_only[0]:,.0f} | {n / measured[0]:,.0f} | {peer_rate} | {ratio} |")
    lines += ["", "Pose only: the matcher alone (auto includes its region lookup under every footprint, and "
              "by default its escalation: the certificate's two footprint passes and the reference for the "
              "poses that fail it); "
              "with penetration and gap: plus the exact footprint pass and the region column, as `replay` "
              "writes them. The peer column counts only the ray casts (the plane arithmetic would add to it)."]
    lines += grid_layout_rows(raw, size, vehicle, x, y, yaw, repeats, surface)
    save_report("\n".join(lines), args.out)


def grid_layout_rows(raw, size, vehicle, x, y, yaw, repeats, mesh_surface):
    """The same DEM in the grid layout, read by window from a store on disk, against the mesh layout."""
    import tempfile

    from tankcd_cli.io.dem_source import DemSourceInfo
    from tankcd_cli.matching.match import MATCHERS, match
    from tankcd_cli.terrain.grid.sources import ArrayDem
    from tankcd_cli.terrain.grid.classify import classify_dem
    from tankcd_cli.terrain.grid.store import open_grid

    v = raw.grid.vertex  # row 0 north, as the grid layout's heights
    heights = np.full(v.shape, np.nan)
    heights[v >= 0] = raw.vertices[v[v >= 0], 2]
    grid, info = raw.grid.geometry, DemSourceInfo("bench", "asc")
    n = len(x)
    out = ["", "## The same DEM in the grid layout", "",
           "Posts only, read by window through the tile cache from a store on disk (classified by "
           "`classify_dem`), against the mesh layout above: poses/s and the ratio grid / mesh.", "",
           "| matcher | grid poses/s (pose only) | grid / mesh | grid poses/s (with penetration, gap) | grid / mesh |",
           "| --- | --- | --- | --- | --- |"]
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "grid.h5")
        classify_dem(ArrayDem(heights, grid, info), path)
        grid = open_grid(path)
        for m in MATCHERS + ("auto",):
            rows = []
            for measure in (False, True):
                reps = 1 if (m == "reference" and measure) else repeats
                g = timed(lambda: match(grid, vehicle, x, y, yaw, m, measure=measure, regions=measure or m == "auto"), reps)
                h = timed(lambda: match(mesh_surface, vehicle, x, y, yaw, m, measure=measure,
                                        regions=measure or m == "auto"), reps)
                rows += [f"{n / g[0]:,.0f}", f"{h[0] / g[0]:.2f}x"]
            out.append(f"| {m} | " + " | ".join(rows) + " |")
        q = timed(lambda: grid.height_normal(x, y), repeats)
        h = timed(lambda: mesh_surface.height_normal(x, y), repeats)
        out += ["", f"Height and normal: grid {n / q[0]:,.0f} points/s, {h[0] / q[0]:.2f}x the mesh layout's rate."]
    return out


if __name__ == "__main__":
    sys.exit(main())
