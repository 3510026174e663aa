"""tankcd collide --scene S --poses POSES: the vehicle at given poses against the scene's obstacles."""

from __future__ import annotations

import click

from tankcd_cli.cli.options import no_parquet, no_stdin, refuse_clashes, scene_inputs, verbosity_options
from tankcd_cli.names import EXIT_COLLISION


@click.command(short_help="Test the vehicle at given poses against the scene's obstacles.")
@click.option("--scene", required=True, type=click.Path(), callback=no_stdin, help="Scene TOML.")
@click.option("--poses", "poses_path", required=True, type=click.Path(allow_dash=True),
              callback=no_parquet(".csv", reading=True),
              help="Poses CSV (x, y, z and roll/pitch/yaw_deg or qw..qz; - for stdin).")
@click.option("--events", "events_path", type=click.Path(dir_okay=False, allow_dash=True), default="-",
              show_default=True, callback=no_parquet(".jsonl"),
              help="Events JSON Lines output (- for stdout): the fields replay's obstacle events have.")
@click.option("--all-contacts", is_flag=True, help="Count every touching triangle pair (default: stop at the first).")
@click.option("--fail-on-collision", is_flag=True, help="Exit 1 when any collision is found.")
@click.option("--no-cache", is_flag=True, help="Do not write obstacle trees to the scene's cache.")
@verbosity_options
@click.pass_obj
def collide(report, scene, poses_path, events_path, all_contacts, fail_on_collision, no_cache):
    """Place the scene's vehicle (its mesh, or one generated from the preset) at every
    pose of POSES and report each obstacle it touches, one JSON event per contact, with the
    fields of replay's obstacle events (step, t, kind, a, b, point, contacts). The trees are
    built with the scene's [collision] settings, which the closing line names."""
    from tankcd_cli.collision.obstacles import (
        collide_obstacles,
        load_obstacles,
        scene_vehicle_body,
    )
    from tankcd_cli.io.atomic import output_text
    from tankcd_cli.io.events import event_line
    from tankcd_cli.io.poses_csv import read_poses
    from tankcd_cli.scene import load_scene

    report.kernels()
    step = report.progress("collide")
    sc = load_scene(scene)
    refuse_clashes({"--poses": poses_path, "--scene": scene, **scene_inputs(sc)}, {"--events": events_path})
    obstacles = load_obstacles(sc, cache=not no_cache, progress=step)
    body = scene_vehicle_body(sc)
    c = sc.collision
    method = f"trees: k {c.k}, aabb levels {c.aabb_levels}, split {c.split}, leaf size {c.leaf_size}"
    totals = {"rows": 0, "skipped": 0, "collisions": 0, "node_tests": 0, "tri_tests": 0}

    def run(out):
        for stp, t, R, pos, valid in read_poses(poses_path):
            totals["rows"] += len(stp)
            totals["skipped"] += int((~valid).sum())
            idx = valid.nonzero()[0]
            hits = collide_obstacles(body, obstacles, R[idx], pos[idx], all_contacts=all_contacts)
            totals["node_tests"] += hits.node_tests
            totals["tri_tests"] += hits.tri_tests
            for p, o, part, point, n in zip(hits.pose, hits.obstacle, hits.part, hits.point, hits.contacts):
                i = idx[p]
                out.write(event_line(stp[i], t[i], "obstacle", body.part_names[part], obstacles[o].name,
                                     point=[round(float(v), 4) for v in point], contacts=int(n)))
                totals["collisions"] += 1
            out.flush()

    with output_text(events_path, ".jsonl") as out:
        run(out)
    report.info(f"collide: {totals['rows']:,} poses ({totals['skipped']} without a pose), {len(obstacles)} obstacles, "
                f"{totals['collisions']} collisions; {totals['node_tests']:,} node-pair and {totals['tri_tests']:,} "
                f"triangle tests; {method} ({report.elapsed():.2f} s)")
    if fail_on_collision and totals["collisions"]:
        click.get_current_context().exit(EXIT_COLLISION)
