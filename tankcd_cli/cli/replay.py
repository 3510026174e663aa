"""tankcd replay TRAJECTORY: poses along a trajectory."""

from __future__ import annotations

import sys

import click

from tankcd_cli.cli.options import vehicle_option, verbosity_options


@click.command(short_help="Replay a trajectory: poses to stdout or --poses.")
@click.argument("trajectory", type=click.Path(allow_dash=True))
@click.option("--terrain", "terrain", required=True, type=click.Path(allow_dash=False),
              help="Terrain store from classify, or any terrain input (classified on the fly).")
@click.option("--poses", "poses_path", type=click.Path(dir_okay=False, allow_dash=True), default="-",
              show_default=True, help="Poses CSV output (- for stdout).")
@click.option("--matcher", type=click.Choice(["auto", "two_point", "four_point", "six_point", "reference"]),
              default="auto", show_default=True, help="Terrain matcher (auto: by the region class under the footprint).")
@vehicle_option
@click.option("--up", type=click.Choice(["z", "y"]), default="z", help="Up axis of a terrain mesh classified on the fly.")
@verbosity_options
@click.pass_obj
def replay(report, trajectory, terrain, poses_path, matcher, vehicle_name, up):
    """Replay TRAJECTORY (CSV with t, x, y, yaw_deg; - for stdin) over a terrain:
    one pose row per trajectory row, in order, with the matcher used, the
    region class, and how far the pose is from physical (penetration, gap)."""
    import numpy as np

    from tankcd_cli.io.atomic import atomic_path
    from tankcd_cli.io.poses_csv import format_rows, header
    from tankcd_cli.io.trajectory import read_trajectory
    from tankcd_cli.matching.match import MATCHERS, STATUS
    from tankcd_cli.replay.pipeline import load_terrain_surface, replay_poses
    from tankcd_cli.vehicle import vehicle_preset

    vehicle = vehicle_preset(vehicle_name)
    step = report.progress("replay")
    surface, _ = load_terrain_surface(terrain, up=up, vehicle=vehicle, progress=step)
    counts = {"rows": 0, "status": np.zeros(len(STATUS), int), "matcher": np.zeros(len(MATCHERS), int)}

    def write_all(out):
        out.write(header())
        for chunk, poses in replay_poses(surface, vehicle, read_trajectory(trajectory), matcher):
            out.write(format_rows(chunk.step, chunk.t, poses, MATCHERS, STATUS))
            out.flush()
            counts["rows"] += len(chunk)
            counts["status"] += np.bincount(poses.status, minlength=len(STATUS))
            counts["matcher"] += np.bincount(poses.matcher, minlength=len(MATCHERS))
            step(f"{counts['rows']:,} rows")

    if poses_path == "-":
        write_all(sys.stdout)
    else:
        with atomic_path(poses_path, ".csv") as tmp:
            with open(tmp, "w", newline="") as out:
                write_all(out)
    used = ", ".join(f"{name} {c}" for name, c in zip(MATCHERS, counts["matcher"]) if c)
    status = ", ".join(f"{name} {c}" for name, c in zip(STATUS, counts["status"]) if c)
    report.info(f"replay: {counts['rows']:,} rows; matchers: {used or 'none'}; status: {status or 'none'} "
                f"({report.elapsed():.2f} s)")
