"""tankcd export TRAJECTORY: any trajectory input as the trajectory CSV tankcd reads, in the terrain's CRS."""

from __future__ import annotations

import click

from tankcd_cli import api
from tankcd_cli.cli.options import no_parquet, no_stdin, refuse_clashes, verbosity_options
from tankcd_cli.io.trajectory.formats import FAMILIES, FORMAT_NAMES
from tankcd_cli.names import UP_AXES


@click.command(short_help=f"Write a trajectory ({', '.join(FAMILIES)}) as the CSV replay reads.")
@click.argument("trajectory", type=click.Path(dir_okay=False), callback=no_stdin)
@click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True), default="-", show_default=True,
              callback=no_parquet(".csv"), help="The trajectory CSV (- for stdout).")
@click.option("--scene", type=click.Path(), default=None, callback=no_stdin,
              help="Convert to the CRS of this scene's terrain.")
@click.option("--terrain", type=click.Path(), default=None, callback=no_stdin,
              help="Convert to the CRS of this terrain (a store is read in place; other inputs are classified).")
@click.option("--crs", default=None, metavar="CRS",
              help="Convert to this CRS (EPSG:32633, WKT) instead of a terrain's; EPSG:4326: lon, lat, heading_deg.")
@click.option("--format", "fmt", type=click.Choice(FORMAT_NAMES, case_sensitive=False), default=None,
              help="The input's format when its suffix does not say (default: the suffix, else the first bytes).")
@click.option("--up", type=click.Choice(UP_AXES), default=None, help="Up axis of a terrain mesh given by --terrain.")
@verbosity_options
@click.pass_obj
def export(report, trajectory, output, scene, terrain, crs, fmt, up):
    """Write TRAJECTORY (a trajectory CSV, a geographic CSV, a GPX track or a
    DIS capture) as the trajectory CSV tankcd reads: t, entity, x, y, yaw_deg
    (and turret_deg, gun_deg where the input has them), the rows in the
    reader's order, positions in the CRS of --terrain, --scene's terrain or
    --crs (a geographic input needs one; headings get the grid's
    convergence); --crs EPSG:4326 writes lon, lat, heading_deg (a compass
    bearing). An input's absolute clock (GPX, a capture, ISO 8601 times) is
    kept in a '# time_origin:' line before the header. For inspection, and
    for other tools: replaying the export gives the same poses as replaying
    the input. Written beside OUTPUT and renamed when complete."""
    if sum(v is not None for v in (scene, terrain, crs)) > 1:
        raise click.UsageError("give at most one of --scene, --terrain and --crs")
    refuse_clashes({"TRAJECTORY": trajectory, "--scene": scene, "--terrain": terrain}, {"--output": output})
    done = api.export_trajectory(trajectory, output, scene=scene, terrain=terrain, crs=crs, fmt=fmt, up=up)
    skipped = ", ".join(f"{n:,} {why}" for why, n in done["skipped"].items() if n)
    report.info(f"export: {done['rows']:,} rows of {done['entities']:,} entities to {output}"
                + (f"; skipped {skipped}" if skipped else ""))
