"""tankcd report POSES EVENTS -o OUT: a replay's outputs as what reviewers open (a page, GeoJSON,
CZML, a DIS capture with Collision PDUs), chosen by OUT's suffix."""

from __future__ import annotations

import click

from tankcd_cli.cli.options import no_stdin, vehicle_option, verbosity_options
from tankcd_cli.names import UP_AXES

REPORT_VEHICLE_HELP = ("Vehicle preset whose hull footprint is drawn, with --terrain (a scene's [vehicle] table "
                       "decides with --scene).")


@click.command(short_help="A replay's poses and events as a page, GeoJSON, CZML or a capture with Collision PDUs.")
@click.argument("poses", type=click.Path(dir_okay=False))
@click.argument("events", type=click.Path(dir_okay=False))
@click.option("--scene", type=click.Path(), default=None, callback=no_stdin,
              help="The scene the replay ran in (its terrain, CRS and vehicles).")
@click.option("--terrain", type=click.Path(), default=None,
              help="The terrain the replay ran on (a store or any terrain input), instead of a scene.")
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="What to write, by its suffix: .html (the review page), .geojson, .czml, .pcap (with --capture).")
@click.option("--capture", type=click.Path(dir_okay=False), default=None,
              help="With a .pcap output: the DIS capture that was replayed; its packets are copied, with a "
                   "Collision PDU per contact among them.")
@vehicle_option(help_text=REPORT_VEHICLE_HELP)
@click.option("--up", type=click.Choice(UP_AXES), default=None,
              help="Up axis of a terrain mesh classified on the fly (default: the format's convention).")
@verbosity_options
@click.pass_obj
def report(reporter, poses, events, scene, terrain, output, capture, vehicle_name, up):
    """Turn a replay's POSES (CSV or Parquet) and EVENTS (JSON Lines or Parquet) into what
    reviewers open, chosen by the suffix of -o OUT: .html one self-contained page (the terrain,
    every track and event, a time slider); .geojson (RFC 7946, the terrain needs a CRS); .czml
    (Cesium); .pcap the --capture that was replayed with a DIS Collision PDU per contact.

    The poses and events are checked against each other first (every event's step, entity and
    time a pose row's): a mismatch is bad input (exit 3), and nothing is written."""
    from tankcd_cli import api

    if (scene is None) == (terrain is None):
        raise click.UsageError("give --scene or --terrain (one of them): the world the replay ran in")
    result = api.report(poses, events, output, scene=scene, terrain=terrain, capture=capture, vehicle=vehicle_name,
                        up=up, progress=reporter.progress("report"))
    reporter.info(f"{closing_line(result)} ({reporter.elapsed():.2f} s)")


def closing_line(result: dict) -> str:
    """What a review wrote (``api.report``'s result), in one line for stderr."""
    def counted(n: int, what: str) -> str:
        return f"{n:,} {what}{'' if n == 1 else 's'}"

    pdus = f", {counted(result['pdus'], 'Collision PDU')} added" if "pdus" in result else ""
    return (f"report: {counted(result['vehicles'], 'vehicle')}, {counted(result['events'], 'event')}{pdus}; "
            f"wrote {result['output']} ({result['bytes']:,} bytes)")
