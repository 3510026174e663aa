"""tankcd replay TRAJECTORY: poses along a trajectory, and the collision events the scene calls for."""

from __future__ import annotations

import sys

import click

from tankcd_cli.cli.options import vehicle_option, verbosity_options


@click.command(short_help="Replay a trajectory: poses to stdout or --poses, events to --events.")
@click.argument("trajectories", nargs=-1, required=True)
@click.option("--scene", type=click.Path(), default=None,
              help="Scene TOML: terrain, vehicle, obstacles; it decides which effects run.")
@click.option("--terrain", "terrain", type=click.Path(), default=None,
              help="Terrain store, or any terrain input (classified on the fly), instead of a scene.")
@click.option("--poses", "poses_path", type=click.Path(dir_okay=False, allow_dash=True), default="-",
              show_default=True, help="Poses CSV output (- for stdout).")
@click.option("--events", "events_path", type=click.Path(dir_okay=False, allow_dash=True), default=None,
              help="Events JSON Lines output (collisions, terrain contact, off-terrain).")
@click.option("--matcher", type=click.Choice(["auto", "two_point", "four_point", "six_point", "reference"]),
              default="auto", show_default=True, help="Terrain matcher (auto: by the region class under the footprint).")
@vehicle_option
@click.option("--up", type=click.Choice(["z", "y"]), default="z", help="Up axis of a terrain mesh classified on the fly.")
@click.option("--cache", is_flag=True, help="Save a terrain classified on the fly as a store beside it, and reuse it.")
@click.option("--fail-on-collision", is_flag=True, help="Exit 1 when any collision (obstacle, internal, terrain) occurs.")
@click.option("--summary", "summary_json", is_flag=True, help="Print the closing summary as one JSON line on stderr.")
@click.option("--out-dir", type=click.Path(file_okay=False), default=None,
              help="Fleet mode: one poses and one events file per trajectory here, and fleet.json.")
@click.option("--jobs", type=click.IntRange(1, 512), default=None,
              help="Fleet mode: parallel processes (default: the number of cores).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Fleet mode on a Dask cluster (tcp://host:8786; pip install 'tankcd[dask]').")
@click.option("--split-lines", type=click.IntRange(1000, None), default=1_000_000, show_default=True,
              help="Fleet mode: replay a longer trajectory as parts of this many lines on several workers.")
@verbosity_options
@click.pass_obj
def replay(report, trajectories, scene, terrain, poses_path, events_path, matcher, vehicle_name, up, cache,
           fail_on_collision, summary_json, out_dir, jobs, scheduler, split_lines):
    """Replay TRAJECTORY (CSV with t, x, y, yaw_deg, optional turret_deg, gun_deg; - for stdin):
    one pose row per trajectory row, in order, streamed in chunks, and the events of the
    effects the scene calls for (no obstacles, no obstacle checks; no drums or no turret
    motion, no gun checks; the hull bottom against the terrain always).

    Fleets: several trajectories, globs ('runs/*.csv') or list files (@runs.txt) with --out-dir
    replay each into OUT/NAME.poses.csv and OUT/NAME.events.jsonl, in parallel (--jobs) or on a
    Dask cluster (--scheduler), and write OUT/fleet.json. A failing trajectory does not stop the
    others; the exit code is 3 (bad input) or 4 (internal error) if any failed."""
    import os

    fleet_mode = out_dir is not None or jobs is not None or scheduler is not None or len(trajectories) > 1 \
        or any((t.startswith("@") or any(ch in t for ch in "*?[")) and not os.path.exists(t) for t in trajectories)
    if (scene is None) == (terrain is None):
        raise click.UsageError("give --scene or --terrain (one of them)")
    if fleet_mode:
        return _fleet(report, trajectories, scene, terrain, matcher, vehicle_name, up, out_dir, jobs, scheduler,
                      fail_on_collision, summary_json, split_lines)
    trajectory = trajectories[0]
    import itertools
    import json

    from tankcd_cli.io.atomic import atomic_path
    from tankcd_cli.io.trajectory import read_trajectory
    from tankcd_cli.replay.pipeline import load_terrain_surface, prepare
    from tankcd_cli.replay.run import new_counts, summary, write_replay
    from tankcd_cli.vehicle import vehicle_preset

    if events_path == "-" and poses_path == "-":
        raise click.UsageError("poses already go to stdout: give --poses FILE to send events there")
    report.kernels()
    step = report.progress("replay")
    sc = None
    if scene:
        from tankcd_cli.replay.scene import load_scene

        sc = load_scene(scene)
        if sc.terrain_path is None:
            from tankcd_cli.errors import InputError

            raise InputError(scene, "names no [terrain] path; replay needs a terrain", where="[terrain] path")
        vehicle, terrain, up = sc.vehicle, sc.terrain_path, sc.terrain_up
    else:
        vehicle = vehicle_preset(vehicle_name)
    surface, _ = load_terrain_surface(terrain, up=up, vehicle=vehicle, progress=step, cache=cache)

    chunks = read_trajectory(trajectory)
    first = next(chunks, None)
    turret_moves = bool(first is not None and first.has_turret)
    setup = prepare(surface, vehicle, sc, turret_moves, progress=step)
    counts = new_counts()

    def write_all(out, ev_out):
        stream = itertools.chain([first] if first else [], chunks)
        write_replay(setup, stream, matcher, out, ev_out, counts, on_chunk=lambda n: report.bar(f"replay: {n:,} rows"))
        report.bar(None)

    def with_events(out):
        if events_path is None:
            write_all(out, None)
        elif events_path == "-":
            write_all(out, sys.stdout)
        else:
            with atomic_path(events_path, ".jsonl") as tmp:
                with open(tmp, "w") as ev:
                    write_all(out, ev)

    if poses_path == "-":
        with_events(sys.stdout)
    else:
        with atomic_path(poses_path, ".csv") as tmp:
            with open(tmp, "w", newline="") as out:
                with_events(out)
    result = summary(counts, setup, report.elapsed())
    collisions = sum(result["collisions"].values())
    if summary_json:
        click.echo(json.dumps(result), err=True)
    else:
        kinds = ", ".join(f"{k} {v}" for k, v in result["collisions"].items())
        ran = ", ".join(k for k, v in setup.effects.items() if v)
        report.info(f"replay: {counts['rows']:,} rows; collisions: {kinds}; off terrain {result['off_terrain']}; "
                    f"effects: {ran} ({report.elapsed():.2f} s)")
    if fail_on_collision and collisions:
        click.get_current_context().exit(1)


def _fleet(report, trajectories, scene, terrain, matcher, vehicle_name, up, out_dir, jobs, scheduler,
           fail_on_collision, summary_json, split_lines):
    import json
    import os

    from tankcd_cli.replay.fleet import World, classified_world, expand_trajectories, plan_tasks, run_fleet, write_summary

    if out_dir is None:
        raise click.UsageError("several trajectories need --out-dir (one poses and one events file each)")
    if "-" in trajectories:
        raise click.UsageError("a fleet reads files, not standard input")
    paths = expand_trajectories(list(trajectories))
    os.makedirs(out_dir, exist_ok=True)
    tasks = plan_tasks(paths, out_dir, split_lines)
    report.kernels()
    step = report.progress("replay")
    world = World(os.path.abspath(scene) if scene else None, os.path.abspath(terrain) if terrain else None,
                  vehicle_name, up, matcher)
    jobs = jobs or os.cpu_count() or 1
    if (scheduler or jobs > 1) and len(tasks) > 1:  # classify once, not once per worker
        world = classified_world(world, out_dir, step)
    finished = []

    def on_result(r):
        finished.append(r)
        report.bar(f"replay: {len(finished)}/{len(tasks)} tasks")

    fleet = run_fleet(world, tasks, jobs, scheduler, progress=step, on_result=on_result)
    report.bar(None)
    for failure in fleet["failures"]:
        click.echo(f"tankcd: error: {failure['error']}", err=True)
    write_summary(os.path.join(out_dir, "fleet.json"), fleet)
    if summary_json:
        click.echo(json.dumps({k: v for k, v in fleet.items() if k != "results"}), err=True)
    else:
        kinds = ", ".join(f"{k} {v}" for k, v in fleet["collisions"].items())
        report.info(f"replay: {fleet['ok']}/{fleet['trajectories']} trajectories, {fleet['rows']:,} rows on "
                    f"{fleet['ran_on']}; collisions: {kinds}; {fleet['failed']} failed; wrote {out_dir}/fleet.json "
                    f"({report.elapsed():.2f} s)")
    statuses = {f["status"] for f in fleet["failures"]}
    ctx = click.get_current_context()
    if "internal_error" in statuses:
        ctx.exit(4)
    if "bad_input" in statuses:
        ctx.exit(3)
    if fail_on_collision and sum(fleet["collisions"].values()):
        ctx.exit(1)
