"""Benchmark: the vehicle against obstacle scenes, tankcd's trees against python-fcl and coal.

    pip install ".[bench]" python-fcl coal
    python benchmarks/bench_collide.py [--quick] [--out benchmarks/results/collide.md]

One run, the same meshes and poses for every method: a generated T-72 mesh of
about 14 000 triangles against a town of buildings of about 50 000 and one of
about 500 000 triangles, 2 000 poses with roughly 40 % colliding and 20 of
them moved to within a centimetre of a wall. Boolean queries (first contact).
Peers are queried one pose at a time from a Python loop (neither has a batch
API); tankcd answers the whole batch in one call, on one thread and on both.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))


def town(target_triangles: int, seed: int = 0):
    from tankcd_cli.vehicle_mesh import box

    rng = np.random.default_rng(seed)
    per_box = 12 * 4 * 4
    count = max(1, target_triangles // per_box)
    side = np.sqrt(count) * 16.0
    tris = []
    for _ in range(count):
        c = rng.uniform(0, side, 2)
        w, d, h = rng.uniform(4, 10), rng.uniform(4, 10), rng.uniform(3, 12)
        tris.append(box([c[0] - w / 2, c[1] - d / 2, 0], [c[0] + w / 2, c[1] + d / 2, h], 4))
    return np.concatenate(tris), side


def poses(n, side, rng):
    from tankcd_cli.geometry.pose import rotation_matrix

    xy = rng.uniform(0, side, (n, 2))
    yaw = rng.uniform(-np.pi, np.pi, n)
    roll, pitch = rng.normal(0, 0.03, n), rng.normal(0, 0.05, n)
    R = rotation_matrix(roll, pitch, yaw)
    t = np.column_stack([xy, np.full(n, 0.05)])
    return R, t


def timed(fn, repeats=3):
    """Median, fastest and slowest seconds of ``repeats`` calls after a warm-up (the trade-off report's)."""
    from tankcd_cli.tradeoff.timing import timed as median_of

    return median_of(fn, repeats)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="the 50k scene only, 500 poses")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "collide.md"))
    args = ap.parse_args()
    from tankcd_cli.threads import get_num_threads, set_num_threads

    from tankcd_cli.bvh.build import build_tree
    from tankcd_cli.bvh.query import collide
    from tankcd_cli.bvh.store import read_tree, write_tree
    from tankcd_cli.vehicle import vehicle_preset
    from tankcd_cli.vehicle_mesh import vehicle_mesh

    tank, _ = vehicle_mesh(vehicle_preset("t72"), 8)
    n_poses = 500 if args.quick else 2000
    scenes = [50_000] if args.quick else [50_000, 500_000]
    threads = get_num_threads()
    lines = ["# Benchmark: vehicle against obstacles", "",
             f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
             f"{platform.python_version()}. Tank {len(tank):,} triangles, {n_poses:,} poses, boolean queries; "
             "medians of 3 (min-max).", ""]
    for target in scenes:
        world, side = town(target)
        rng = np.random.default_rng(1)
        R, t = poses(n_poses, side, rng)
        tb_ref = build_tree(world, k=18)
        ta_ref = build_tree(tank, k=18)
        hit = collide(ta_ref, tb_ref, R, t).hit
        # move 20 colliding poses back until they are free, to within 1 cm (bisection)
        graze = np.flatnonzero(hit)[:20]
        for i in graze:
            lo, hi = 0.0, 20.0
            fwd = R[i][:, 0]
            while hi - lo > 0.005:
                mid = 0.5 * (lo + hi)
                if collide(ta_ref, tb_ref, R[i:i + 1], t[i:i + 1] - mid * fwd).hit[0]:
                    lo = mid
                else:
                    hi = mid
            t[i] = t[i] - hi * fwd
        hit = collide(ta_ref, tb_ref, R, t).hit
        lines += [f"## Town of {len(world):,} triangles: {hit.mean():.0%} of the poses collide, "
                  f"{len(graze)} free within 1 cm", "",
                  "| method | build s (tank + town) | query us/pose | poses/s | node-pair tests/pose | triangle tests/pose | agrees |",
                  "| --- | --- | --- | --- | --- | --- | --- |"]
        rows = []
        for k, levels, split in ((6, 0, "sah"), (14, 0, "sah"), (18, 0, "sah"), (26, 0, "sah"),
                                 (18, 1, "sah"), (18, 2, "sah"), (18, 4, "sah"), (18, 2, "median")):
            t0 = time.perf_counter()
            ta = build_tree(tank, k=k, aabb_levels=levels, split=split)
            tb = build_tree(world, k=k, aabb_levels=levels, split=split)
            build = time.perf_counter() - t0
            res = collide(ta, tb, R, t)
            set_num_threads(1)
            one = timed(lambda: collide(ta, tb, R, t))
            set_num_threads(threads)
            both = timed(lambda: collide(ta, tb, R, t))
            name = f"tankcd k={k}" + (f" hybrid {levels} AABB levels" if levels else (" (AABB)" if k == 6 else "")) + \
                (" median split" if split == "median" else "")
            agree = (res.hit == hit).all()
            rows.append((name + ", 1 thread", build, one[0], res, agree))
            rows.append((name + f", {threads} threads", build, both[0], res, agree))
        # save and load
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "town.h5")
            tb = build_tree(world, k=18, aabb_levels=2, split="sah")
            s = time.perf_counter()
            write_tree(path, tb)
            save = time.perf_counter() - s
            load = timed(lambda: read_tree(path), 3)[0]
            size = os.path.getsize(path)
            build18 = timed(lambda: build_tree(world, k=18, aabb_levels=2, split="sah"), 1)[0]
        for name, build, q, res, agree in rows:
            lines.append(f"| {name} | {build:.2f} | {q / n_poses * 1e6:.1f} | {n_poses / q:,.0f} | "
                         f"{res.node_tests.mean():.0f} | {res.tri_tests.mean():.0f} | {'yes' if agree else 'NO'} |")
        for peer in ("fcl", "coal"):
            try:
                build, q, agree = _peer(peer, tank, world, R, t, hit)
                lines.append(f"| {peer} (OBBRSS), Python loop | {build:.2f} | {q / n_poses * 1e6:.1f} | {n_poses / q:,.0f} | | | "
                             f"{'yes' if agree else 'NO'} |")
            except ImportError:
                lines.append(f"| {peer} | not installed | | | | | |")
        lines += ["", "Split rule: the surface-area heuristic unless the row says median.", "",
                  f"Tree file of the town (k = 18, hybrid 2): {size / 1e6:.1f} MB; save {save:.2f} s, "
                      f"load {load:.3f} s, build {build18:.2f} s (load / build = {load / build18:.2f}).", ""]
    save_report("\n".join(lines), args.out)


def _peer(name, tank, world, R, t, truth):
    from tankcd_cli.tradeoff.peers import peer_query

    peer = peer_query(name, tank, world, R, t)
    if peer is None:
        raise ImportError(name)
    run, build = peer
    answer = run()
    q = timed(run, 3)[0]
    return build, q, bool((answer == truth).mean() > 0.99)


if __name__ == "__main__":
    main()
