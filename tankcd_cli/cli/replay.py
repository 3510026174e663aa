"""tankcd replay TRAJECTORY: poses along a trajectory, and the collision events the scene calls for."""

from __future__ import annotations

import sys

import click

from tankcd_cli.cli.options import vehicle_option, verbosity_options


@click.command(short_help="Replay a trajectory: poses to stdout or --poses, events to --events.")
@click.argument("trajectory", type=click.Path(allow_dash=True))
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
@verbosity_options
@click.pass_obj
def replay(report, trajectory, scene, terrain, poses_path, events_path, matcher, vehicle_name, up, cache,
           fail_on_collision, summary_json):
    """Replay TRAJECTORY (CSV with t, x, y, yaw_deg, optional turret_deg, gun_deg; - for stdin):
    one pose row per trajectory row, in order, streamed in chunks, and the events of the
    effects the scene calls for (no obstacles, no obstacle checks; no drums or no turret
    motion, no gun checks; the hull bottom against the terrain always)."""
    import itertools
    import json

    import numpy as np

    from tankcd_cli.io.atomic import atomic_path
    from tankcd_cli.io.events import event_line
    from tankcd_cli.io.poses_csv import format_rows, header
    from tankcd_cli.io.trajectory import read_trajectory
    from tankcd_cli.matching.match import MATCHERS, STATUS
    from tankcd_cli.replay.pipeline import load_terrain_surface, prepare, replay_chunks
    from tankcd_cli.vehicle import vehicle_preset

    if (scene is None) == (terrain is None):
        raise click.UsageError("give --scene or --terrain (one of them)")
    if events_path == "-" and poses_path == "-":
        raise click.UsageError("poses already go to stdout: give --poses FILE to send events there")
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
    counts = {"rows": 0, "status": np.zeros(len(STATUS), int), "matcher": np.zeros(len(MATCHERS), int),
              "events": {"obstacle": 0, "internal": 0, "terrain": 0, "off_terrain": 0}}

    def write_all(out, ev_out):
        out.write(header())
        for chunk, poses, events in replay_chunks(setup, itertools.chain([first] if first else [], chunks), matcher):
            out.write(format_rows(chunk.step, chunk.t, poses, MATCHERS, STATUS))
            out.flush()
            for e in events:
                counts["events"][e.kind] += 1
                if ev_out is not None:
                    ev_out.write(event_line(e.step, e.t, e.kind, e.a, e.b, **e.extra))
            counts["rows"] += len(chunk)
            counts["status"] += np.bincount(poses.status, minlength=len(STATUS))
            counts["matcher"] += np.bincount(poses.matcher, minlength=len(MATCHERS))
            report.bar(f"replay: {counts['rows']:,} rows")
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
    collisions = sum(counts["events"][k] for k in ("obstacle", "internal", "terrain"))
    summary = {"rows": counts["rows"], "collisions": {k: counts["events"][k] for k in ("obstacle", "internal", "terrain")},
               "off_terrain": counts["events"]["off_terrain"], "effects": setup.effects,
               "matchers": {name: int(c) for name, c in zip(MATCHERS, counts["matcher"]) if c},
               "seconds": round(report.elapsed(), 3),
               "seconds_by_effect": {k: round(v, 3) for k, v in setup.seconds.items()}}
    if summary_json:
        click.echo(json.dumps(summary), err=True)
    else:
        kinds = ", ".join(f"{k} {v}" for k, v in summary["collisions"].items())
        ran = ", ".join(k for k, v in setup.effects.items() if v)
        report.info(f"replay: {counts['rows']:,} rows; collisions: {kinds}; off terrain {summary['off_terrain']}; "
                    f"effects: {ran} ({report.elapsed():.2f} s)")
    if fail_on_collision and collisions:
        click.get_current_context().exit(1)
