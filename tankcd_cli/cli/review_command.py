"""tankcd report POSES EVENTS: a replay's outputs as a page, GeoJSON, CZML or a capture with Collision PDUs."""

from __future__ import annotations

import click

from tankcd_cli import api
from tankcd_cli.cli.options import no_stdin, refuse_clashes, vehicle_option, verbosity_options
from tankcd_cli.names import UP_AXES


@click.command(short_help="A replay's poses and events as a page, GeoJSON, CZML or DIS Collision PDUs.")
@click.argument("poses", type=click.Path(dir_okay=False), callback=no_stdin)
@click.argument("events", type=click.Path(dir_okay=False), callback=no_stdin)
@click.option("-o", "--output", type=click.Path(dir_okay=False), required=True,
              help="The report: .html (the page), .geojson, .czml, or .pcap (with --capture).")
@click.option("--scene", type=click.Path(), default=None, callback=no_stdin,
              help="The scene the replay ran in (its terrain and vehicles).")
@click.option("--terrain", type=click.Path(), default=None, callback=no_stdin,
              help="The terrain the replay ran on (a store is read in place), instead of --scene.")
@click.option("--capture", type=click.Path(dir_okay=False), default=None, callback=no_stdin,
              help="The DIS capture that was replayed: a .pcap report is it with a Collision PDU per contact.")
@vehicle_option(help_text="Vehicle preset with --terrain (a scene names its own): its footprint and mass.")
@click.option("--up", type=click.Choice(UP_AXES), default=None, help="Up axis of a terrain mesh given by --terrain.")
@verbosity_options
@click.pass_obj
def report(reporter, poses, events, output, scene, terrain, capture, vehicle_name, up):
    """Write what reviewers open from a replay's POSES (CSV or Parquet) and
    EVENTS (JSON Lines or Parquet), one vehicle or an exercise, by OUTPUT's
    suffix: .html a self-contained page (the terrain, every track and event,
    a time slider and playback, the event list, a table per vehicle, filters,
    the run's provenance); .geojson (RFC 7946, WGS 84) for GIS; .czml for
    Cesium; .pcap with --capture: the replayed DIS capture with a Collision
    PDU for each contact. The poses and events must come from one run (exit
    3 otherwise), GeoJSON and CZML need a terrain with a CRS. Written beside
    OUTPUT and renamed when complete."""
    if (scene is None) == (terrain is None):
        raise click.UsageError("give --scene or --terrain (one of them)")
    refuse_clashes({"POSES": poses, "EVENTS": events, "--scene": scene, "--terrain": terrain, "--capture": capture},
                   {"--output": output})
    done = api.report(poses, events, output, scene=scene, terrain=terrain, capture=capture, vehicle=vehicle_name, up=up,
                      progress=reporter.progress("report"))
    extra = f", {done.pdus:,} Collision PDUs" if output.lower().endswith(".pcap") else ""
    reporter.info(f"report: {done.vehicles:,} vehicles, {done.events:,} events{extra} to {output} "
                  f"({done.bytes / 2**20:,.1f} MiB, {reporter.elapsed():.1f} s)")
