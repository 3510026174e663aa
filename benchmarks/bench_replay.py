"""Benchmark: `tankcd replay` end to end (whole process) on the sample terrain, or on a game-sized DEM.

    python benchmarks/bench_replay.py [--rows 100000] [--repeats 7] [--out benchmarks/results/replay.md]
    python benchmarks/bench_replay.py --dem [--rows 1000000] [--before CHECKOUT] [--repeats 5]
        [--out benchmarks/results/replay_dem.md]

A wandering trajectory of ROWS rows over the sample battlefield, replayed as a
user would run it (a fresh process, the terrain store read from disk, poses
written to a file): terrain only (no obstacles, no drums), the sample scene
with its obstacles and drums and a moving turret, and matching alone
(`--terrain`) for comparison. Reports rows/s and, from `--summary`, the share
of time per effect.

Then a ``four_point`` replay against the ray caster a user would write (``embree_rays``, trimesh's
embree: four rays a row), both as whole processes, alternated (where embreex is installed).

Then what the check along the motion between rows (the default) costs against
`--discrete` (the rows alone), runs alternated, REPEATS pairs, the ratio's
median and range over the pairs: the sample scene with every effect at 10 Hz
(target: at most 1.25x), the same drive logged at 1 Hz (ROWS rows 5 m apart,
reported), and a scene whose obstacles the path never approaches (the drive
held to the west of the battlefield, the depot and the wall moved to its east
end: target at most 1.05x).

With ``--dem``: a made DEM like a 1 km game terrain (``ridged_dem``: 512 x 512 posts at 2 m,
ridged fractal noise, heights +-30 m), classified to a grid store, and a random walk of ROWS
rows at 10 Hz over it (``dem_walk``), T-72 terrain only: the default replay (``auto``,
escalating) and ``--no-escalate``, and with ``--before`` both again as another checkout of
tankcd runs them (its folder put first on PYTHONPATH), every case once a round.
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


def embree_rays(dem: str, traj: str) -> dict:
    """The peer a user would write: the DEM as a triangle mesh (two triangles a cell), trimesh's
    embree intersector, and one ray straight down at each footprint corner of every row (4 a row,
    T-72: +-track_length / 2 along, +-(gauge + track width) / 2 across). Timed: the tree's build
    and the rays alone (no reading, no writing, no plane through the hits)."""
    import trimesh

    from tankcd_cli.vehicle import vehicle_preset

    with open(dem) as fh:
        head = dict(fh.readline().split() for _ in range(6))
    n, m = int(head["nrows"]), int(head["ncols"])
    cell, x0, y0 = float(head["cellsize"]), float(head["xllcenter"]), float(head["yllcenter"])
    z = np.loadtxt(dem, skiprows=6)[::-1]  # row 0 south
    gx, gy = np.meshgrid(x0 + cell * np.arange(m), y0 + cell * np.arange(n))
    vertices = np.column_stack([gx.ravel() - x0, gy.ravel() - y0, z.ravel()])  # local: float precision
    k = np.arange(n * m).reshape(n, m)[:-1, :-1].ravel()
    faces = np.concatenate([np.column_stack([k, k + 1, k + m + 1]), np.column_stack([k, k + m + 1, k + m])])
    rows = np.loadtxt(traj, delimiter=",", skiprows=1)
    v = vehicle_preset("t72")
    half_l, half_w = v.track_length / 2, (v.track_gauge + v.track_width) / 2
    c, s = np.cos(np.radians(rows[:, 3])), np.sin(np.radians(rows[:, 3]))
    origins = []
    for u, w in ((half_l, half_w), (half_l, -half_w), (-half_l, half_w), (-half_l, -half_w)):
        origins.append(np.column_stack([rows[:, 1] - x0 + c * u - s * w, rows[:, 2] - y0 + s * u + c * w,
                                        np.full(len(rows), z.max() + 10.0)]))
    origins = np.concatenate(origins)
    down = np.tile([0.0, 0.0, -1.0], (len(origins), 1))
    start = time.perf_counter()
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    caster = trimesh.ray.ray_pyembree.RayMeshIntersector(mesh)
    caster.intersects_first(origins[:8], down[:8])  # the scene is built on the first cast
    built = time.perf_counter() - start
    start = time.perf_counter()
    hit = caster.intersects_first(origins, down)
    rays = time.perf_counter() - start
    return {"build_s": built, "rays_s": rays, "rays": int(len(origins)), "hits": int((hit >= 0).sum())}


def peer_process(dem: str, traj: str) -> tuple[float, dict]:
    """``embree_rays`` in a fresh process (start-up, imports, reading the DEM and the rows with numpy,
    the scene's build, the rays): its whole wall seconds, and what it timed inside."""
    s = time.perf_counter()
    got = subprocess.run([sys.executable, os.path.abspath(__file__), "--embree-peer", dem, traj],
                         capture_output=True, text=True, check=True)
    return time.perf_counter() - s, json.loads(got.stdout.strip().splitlines()[-1])


def has_embree() -> bool:
    try:
        import trimesh

        return bool(trimesh.ray.has_embree)
    except ImportError:
        return False


def ridged_dem(path, posts=512, spacing=2.0, relief=30.0, gain=0.4, seed=7):
    """Write an ESRI ASCII DEM of ``posts`` x ``posts`` at ``spacing`` m: ridged value noise of
    7 octaves (each ``gain`` times the one before), scaled to +-``relief`` m. Returns its
    south-west post's x, y and its side (m)."""
    rng = np.random.default_rng(seed)
    z = np.zeros((posts, posts))
    amp, total = 1.0, 0.0
    for octave in range(1, 8):
        k = 2 ** octave + 1
        g = rng.uniform(-1, 1, (k, k))
        t = np.linspace(0, k - 1, posts)
        i = np.minimum(t.astype(int), k - 2)
        f = t - i
        f = f * f * (3 - 2 * f)
        rows = g[i] * (1 - f)[:, None] + g[i + 1] * f[:, None]
        layer = rows[:, i] * (1 - f)[None, :] + rows[:, i + 1] * f[None, :]
        z += amp * (1 - np.abs(layer)) ** 2  # ridges where the noise crosses zero
        total += amp
        amp *= gain
    z = (z - z.min()) / (z.max() - z.min()) * 2 * relief - relief
    x0, y0 = 300000.0, 5000000.0
    with open(path, "w") as fh:
        fh.write(f"ncols {posts}\nnrows {posts}\nxllcenter {x0}\nyllcenter {y0}\ncellsize {spacing}\n"
                 "NODATA_value -9999\n")
        np.savetxt(fh, z[::-1], fmt="%.3f")
    return x0, y0, (posts - 1) * spacing


def dem_walk(path, rows, x0, y0, size, margin=15.0, seed=5):
    """Write a trajectory of ``rows`` rows at 10 Hz, 5 m/s, wandering over the square terrain of
    side ``size`` m from (x0, y0), folded back at ``margin`` m from its edges (the heading
    mirrored where a fold reverses the travel)."""
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0, 0.02, rows))
    x, y = np.cumsum(0.5 * np.cos(heading)), np.cumsum(0.5 * np.sin(heading))
    span = size - 2 * margin
    sx = np.where(x % (2 * span) < span, -1.0, 1.0)
    sy = np.where(y % (2 * span) < span, -1.0, 1.0)
    x = x0 + margin + np.abs(x % (2 * span) - span)
    y = y0 + margin + np.abs(y % (2 * span) - span)
    yaw = np.degrees(np.arctan2(sy * np.sin(heading), sx * np.cos(heading)))
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg\n")
        np.savetxt(fh, np.column_stack([np.arange(rows) * 0.1, x, y, yaw]), fmt="%.3f", delimiter=",")


def once(args, checkout=None):
    """One fresh process (of tankcd in ``checkout``, else this one's): seconds, peak resident
    memory (MB) and its --summary."""
    env = cwd = None
    if checkout:
        # `python -m` puts the working directory first on sys.path: run in the checkout, or a run from
        # this repository's root would import this tankcd_cli, not the checkout's (the paths are absolute)
        cwd = os.path.abspath(checkout)
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([cwd, os.environ.get("PYTHONPATH", "")])}
    with tempfile.TemporaryFile("w+") as err:
        s = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "tankcd_cli", *args, "--summary"], stdout=subprocess.DEVNULL,
                                stderr=err, env=env, cwd=cwd)
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


def _commit(checkout):
    """The short commit a checkout is at (with '+' when its tracked files differ from it)."""
    head = subprocess.run(["git", "-C", checkout, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", checkout, "diff", "--quiet", "HEAD"]).returncode != 0
    return (head.stdout.strip() or "unknown") + ("+" if dirty else "")


def escalated_share(summary, rows):
    return sum(c for m, c in summary["matchers"].items() if "+" in m) / rows


def dem_main(a):
    """The --dem report: the default replay against --no-escalate and, with --before, against
    another checkout's."""
    rows = a.rows
    with tempfile.TemporaryDirectory() as tmp:
        dem = os.path.join(tmp, "ridged.asc")
        x0, y0, size = ridged_dem(dem)
        store = os.path.join(tmp, "ridged.h5")
        subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", dem, "-o", store], check=True)
        traj = os.path.join(tmp, "walk.csv")
        dem_walk(traj, rows, x0, y0, size)
        scene = os.path.join(tmp, "terrain_only.toml")
        with open(scene, "w") as fh:
            fh.write(f'[terrain]\npath = "{store}"\n[vehicle]\npreset = "t72"\nfuel_drums = false\n')
        only = ["replay", traj, "--scene", scene, "--poses", os.path.join(tmp, "poses.csv")]
        lines = ["# Benchmark: replay end to end on a game-sized DEM", "",
                 f"`python benchmarks/bench_replay.py --dem --rows {rows}"
                 + (" --before CHECKOUT`" if a.before else "`") + ": a made 1 km game terrain (512 x 512 posts at "
                 "2 m, ridged fractal noise, heights +-30 m: `ridged_dem`), classified to a grid store, and a "
                 f"{rows:,}-row random walk at 10 Hz over it (`dem_walk`), T-72 terrain only; a fresh process "
                 f"each run, every case once a round, medians of {a.repeats} rounds (ratios: the median of the "
                 "ratios within a round, smallest-largest in brackets).", ""]
        cases = [("after", "default", only, None), ("after", "--no-escalate", only + ["--no-escalate"], None)]
        if a.before:
            cases += [("before", "default", only, a.before),
                      ("before", "--no-escalate", only + ["--no-escalate"], a.before)]
        runs = {(who, what): [] for who, what, _, _ in cases}
        for _ in range(a.repeats):  # every case once a round: the load is shared alike
            for who, what, args, checkout in cases:
                runs[who, what].append(once(args, checkout))
        seconds = {k: np.array([t for t, _, _ in v]) for k, v in runs.items()}

        def ratio(k1, k2):
            r = seconds[k1] / seconds[k2]
            return f"{np.median(r):.2f}x ({r.min():.2f}-{r.max():.2f})"

        if a.before:
            lines += [f"Before: commit {_commit(a.before)}; after: commit {_commit(os.path.dirname(HERE))}.", ""]
        lines += ["| checkout | replay | seconds | rows/s | peak memory | matching | between rows | terrain contact "
                  "| escalated |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for who, what, _, _ in cases:
            t = float(np.median(seconds[who, what]))
            peak = max(p for _, p, _ in runs[who, what])
            sec = runs[who, what][-1][2]["seconds_by_effect"]
            lines.append(f"| {who} | {what} | {t:.2f} | {rows / t:,.0f} | {peak:,.0f} MB | {sec['matching']:.2f} s | "
                         f"{sec.get('between', 0.0):.2f} s | {sec['terrain']:.2f} s | "
                         f"{escalated_share(runs[who, what][-1][2], rows):.1%} |")
        lines.append("")
        for who in ("before", "after") if a.before else ("after",):
            escalated = escalated_share(runs[who, "default"][-1][2], rows) * rows
            extra = np.median(seconds[who, "default"] - seconds[who, "--no-escalate"]) / max(escalated, 1)
            lines.append(f"- {who}: escalating costs {ratio((who, 'default'), (who, '--no-escalate'))} "
                         f"`--no-escalate`'s whole process, {extra * 1e6:.0f} us more a row escalated (the "
                         "certificate of every row and the escalation of the poses between rows included)")
        if a.before:
            lines += [f"- before / after, the default replay: {ratio(('before', 'default'), ('after', 'default'))}",
                      f"- before / after, `--no-escalate`: "
                      f"{ratio(('before', '--no-escalate'), ('after', '--no-escalate'))}"]
        if not has_embree():
            lines += ["", "trimesh with embree is not installed here (`pip install embreex`): no ray-casting peer "
                          "in this run."]
        else:
            import trimesh

            peer, walls = [], []
            for _ in range(a.repeats):  # a fresh process each, the replay's default beside it in turn
                wall, got = peer_process(dem, traj)
                peer.append(got)
                walls.append(wall)
                seconds["after", "again"] = np.r_[seconds.get(("after", "again"), []), once(only)[0]]
            rays = np.array([p["rays_s"] for p in peer])
            build = np.array([p["build_s"] for p in peer])
            walls = np.array(walls)
            mine = seconds["after", "again"]
            r = mine / rays
            rb = mine / (rays + build)
            rw = mine / walls
            lines += ["", f"The peer a user would write (`embree_rays`): trimesh {trimesh.__version__} with embree, "
                          f"{peer[0]['rays']:,} rays straight down at the four footprint corners of the same rows "
                          f"({peer[0]['hits']:,} hits), the DEM as {2 * 511 * 511:,} triangles; medians of "
                          f"{a.repeats}, each beside a default replay run in turn:", "",
                      "| | seconds |", "| --- | --- |",
                      f"| tankcd replay, default, whole process | {np.median(mine):.2f} |",
                      f"| embree: the rays alone (no reading, no writing, no plane through the hits) | "
                      f"{np.median(rays):.2f} |",
                      f"| embree: building its scene of the DEM | {np.median(build):.2f} |",
                      f"| embree: the peer as a whole process (start-up, imports, reading the DEM and the rows with "
                      f"numpy, the build, the rays; no plane, no writing) | {np.median(walls):.2f} |", "",
                      f"tankcd's whole replay over embree's rays alone: {np.median(r):.2f}x "
                      f"({r.min():.2f}-{r.max():.2f}; "
                      f"target at most 1.5x: {'met' if np.median(r) <= 1.5 else '**not met**'}); over its build and "
                      f"rays: {np.median(rb):.2f}x ({rb.min():.2f}-{rb.max():.2f}); over the peer's whole process, "
                      f"pair by pair: {np.median(rw):.2f}x ({rw.min():.2f}-{rw.max():.2f}; at most 1.5x: "
                      f"{'met' if np.median(rw) <= 1.5 else '**not met**'})."]
    save_report("\n".join(lines + [""]), a.out or os.path.join(HERE, "results", "replay_dem.md"))


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "--embree-peer":  # the peer, in a process of its own
        print(json.dumps(embree_rays(sys.argv[2], sys.argv[3])))
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=None, help="default 100,000 (1,000,000 with --dem)")
    ap.add_argument("--repeats", type=int, default=7, help="pairs behind each ratio (rounds of every case with --dem)")
    ap.add_argument("--only-between", action="store_true",
                    help="only the check along the motion against --discrete (default --out: between_rows.md)")
    ap.add_argument("--out", default=None, help="default: benchmarks/results/replay.md (between_rows.md with "
                                                "--only-between, replay_dem.md with --dem)")
    ap.add_argument("--dem", action="store_true", help="the made game-sized DEM instead of the sample terrain")
    ap.add_argument("--before", default=None, help="with --dem: another checkout to run the same replays with")
    a = ap.parse_args()
    if a.dem:
        a.rows = a.rows or 1_000_000
        return dem_main(a)
    a.rows = a.rows or 100_000
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
        lines += four_point_peer(a, store, traj, out)
        lines += between_rows(a, tmp, store, full, traj, out)
    save_report("\n".join(lines + [""]), a.out)


def four_point_peer(a, store, traj, out):
    """The section on a ``four_point`` replay against the ray caster a user would write, both whole
    processes, alternated: the key-point matcher's plane from four heights a row, and the peer's
    four rays a row (``embree_rays``)."""
    lines = ["", "## `four_point` against the ray caster a user would write", ""]
    if not has_embree():
        return lines + ["trimesh with embree is not installed here (`pip install embreex`): no peer in this run."]
    dem = os.path.join(SAMPLE, "battlefield.asc")
    lines += [f"`tankcd replay --matcher four_point` ({a.rows:,} rows; no escalation) and the peer (`embree_rays`: "
              "trimesh's embree, one ray straight down at each footprint corner of every row, the DEM as two "
              "triangles a cell), each a fresh process, alternated, "
              f"{a.repeats} pairs: medians, the ratio pair by pair (median, lowest-highest). The peer reads the "
              "DEM and the rows with numpy and casts; it fits no plane and writes nothing, and tankcd writes its "
              "poses to a file.", "",
              "| tankcd | tankcd s | peer, whole process, s | peer's rays alone, s | tankcd / peer's process | "
              "tankcd / peer's rays |", "| --- | --- | --- | --- | --- | --- |"]
    for name, extra in (("`--matcher four_point --discrete`", ["--discrete"]),
                        ("`--matcher four_point` (along the motion)", [])):
        mine, walls, rays = [], [], []
        for _ in range(a.repeats):
            wall, got = peer_process(dem, traj)
            walls.append(wall)
            rays.append(got["rays_s"])
            mine.append(once(["replay", traj, "--terrain", store, "--matcher", "four_point", "--poses", out,
                              *extra])[0])
        mine, walls, rays = np.array(mine), np.array(walls), np.array(rays)
        rw, rr = mine / walls, mine / rays
        lines.append(f"| {name} | {np.median(mine):.2f} | {np.median(walls):.2f} | {np.median(rays):.3f} | "
                     f"{np.median(rw):.2f}x ({rw.min():.2f}-{rw.max():.2f}) | "
                     f"{np.median(rr):.1f}x ({rr.min():.1f}-{rr.max():.1f}) |")
    lines += ["", "Issue 33's target: at most 1.5x the peer's cast (whole processes)."]
    return lines


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
