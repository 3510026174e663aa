"""tankcd demo [DIR]: the whole pipeline on the bundled sample data."""

from __future__ import annotations

import click

from tankcd_cli.cli.options import no_dash_directory, verbosity_options
from tankcd_cli.replay.demo import run_demo


@click.command(short_help="Run the whole pipeline on the sample battlefield.")
@click.argument("directory", default="tankcd-demo", type=click.Path(file_okay=False), callback=no_dash_directory)
@verbosity_options
@click.pass_obj
def demo(report, directory):
    """Write the sample battlefield into DIRECTORY (default tankcd-demo), classify it, build
    the obstacles' trees, replay a patrol through a scene with a depot, a wall, and a T-72
    whose turret sweeps round over its rear drums, and draw the path over the class map
    with every collision marked (replay.png)."""
    s = run_demo(directory, progress=report.progress("demo"))
    ev = s["events"]
    report.info(f"demo: {s['rows']:,} rows replayed; obstacle {ev['obstacle']}, internal {ev['internal']}, "
                f"terrain {ev['terrain']} collisions; wrote {', '.join(s['files'])} in {directory} "
                f"({report.elapsed():.2f} s)")
