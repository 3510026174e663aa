"""tankcd collide --scene S --poses POSES: the vehicle at given poses against the scene's obstacles."""

from __future__ import annotations

import json

import click

from tankcd_cli import api
from tankcd_cli.cli.options import no_parquet, no_stdin, refuse_clashes, scene_inputs, verbosity_options
from tankcd_cli.io.atomic import output_text
from tankcd_cli.names import EXIT_COLLISION
from tankcd_cli.scene import load_scene


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
    report.kernels()
    step = report.progress("collide")
    sc = load_scene(scene)
    refuse_clashes({"--poses": poses_path, "--scene": scene, **scene_inputs(sc)}, {"--events": events_path})
    c = sc.collision
    method = f"trees: k {c.k}, aabb levels {c.aabb_levels}, split {c.split}, leaf size {c.leaf_size}"
    totals = {"rows": 0, "skipped": 0, "collisions": 0, "node_tests": 0, "tri_tests": 0}
    with output_text(events_path, ".jsonl") as out:
        for events, stats in api.collide_chunks(scene, poses_path, all_contacts, cache=not no_cache, progress=step):
            totals["rows"] += stats.poses
            totals["skipped"] += stats.skipped
            totals["node_tests"] += stats.node_tests
            totals["tri_tests"] += stats.tri_tests
            totals["collisions"] += len(events)
            out.write("".join(json.dumps(e, separators=(",", ":")) + "\n" for e in events))
            out.flush()
    obstacles = sc.obstacles
    report.info(f"collide: {totals['rows']:,} poses ({totals['skipped']} without a pose), {len(obstacles)} obstacles, "
                f"{totals['collisions']} collisions; {totals['node_tests']:,} node-pair and {totals['tri_tests']:,} "
                f"triangle tests; {method} ({report.elapsed():.2f} s)")
    if fail_on_collision and totals["collisions"]:
        click.get_current_context().exit(EXIT_COLLISION)
