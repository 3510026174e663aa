"""tankcd envelope: the lowest safe gun elevation at every turret azimuth."""

from __future__ import annotations

import click
import numpy as np

from tankcd_cli import api
from tankcd_cli.cli.options import (
    SCENE_VEHICLE,
    VEHICLE_PRESETS,
    check_option_combinations,
    no_parquet,
    no_stdin,
    refuse_clashes,
    verbosity_options,
)
from tankcd_cli.collision.internal import DRUMS, envelope_summary
from tankcd_cli.io.atomic import atomic_path, output_text
from tankcd_cli.plots import envelope_png
from tankcd_cli.scene import load_scene
from tankcd_cli.vehicle import vehicle_preset


@click.command(short_help="Lowest safe gun elevation per turret azimuth (CSV; --png polar plot).")
@click.option("--scene", type=click.Path(), default=None, callback=no_stdin, help="Take the vehicle from this scene.")
@click.option("--vehicle", "vehicle_name", type=click.Choice(VEHICLE_PRESETS), default="t72", show_default=True,
              help="Vehicle preset (without --scene).")
@click.option("--step", "step_deg", type=click.FloatRange(0.01, 90), default=1.0, show_default=True,
              help="Azimuth step, degrees.")
@click.option("--method", type=click.Choice(["exact", "projection"]), default="exact", show_default=True,
              help="exact cylinder test, or the paper's two-plane projection (conservative).")
@click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True), default="-", show_default=True,
              callback=no_parquet(".csv"), help="CSV output (- for stdout).")
@click.option("--png", type=click.Path(dir_okay=False, allow_dash=True), default=None,
              help="Also draw a polar plot (- for stdout, with -o FILE).")
@verbosity_options
@click.pass_obj
def envelope(report, scene, vehicle_name, step_deg, method, output, png):
    """For every turret azimuth (0 = forward, counter-clockwise), the lowest gun elevation at
    which the barrel clears the rear fuel drums, to 0.01 degree (bisection on the exact test).
    Columns: azimuth_deg, min_elevation_deg (empty where even full elevation touches), limited_by
    (the drum that sets the limit, or "gun" where the gun's own depression limit does), checked
    (every elevation above the limit was tested clear on a 0.25 degree grid). A vehicle without
    fuel drums has the gun's own limit at every azimuth, and says so."""
    check_option_combinations(click.get_current_context(), (SCENE_VEHICLE,))
    refuse_clashes({"--scene": scene}, {"-o/--output": output, "--png": png})
    if scene:
        vehicle = load_scene(scene).vehicle
    else:
        vehicle = vehicle_preset(vehicle_name)
    az = np.arange(0.0, 360.0 - 1e-9, step_deg)
    env = api.gun_envelope(vehicle, az, method=method)
    lines = ["azimuth_deg,min_elevation_deg,limited_by,checked\n"]
    for a, e, lim, who, ok in zip(env["azimuth"], env["min_elevation"], env["limited"], env["blocked_by"], env["checked"]):
        by = DRUMS[who] if (lim or not np.isfinite(e)) and who >= 0 else "gun"
        lines.append(f"{a:.3f},{'' if not np.isfinite(e) else f'{e:.2f}'},{by},{str(bool(ok)).lower()}\n")
    text = "".join(lines)
    with output_text(output, ".csv") as fh:
        fh.write(text)
    if png:
        with atomic_path(png, ".png") as tmp:
            envelope_png(vehicle, env, tmp)
    drums = _drums_say(envelope_summary(vehicle, env, step_deg))
    report.info(f"envelope: {vehicle.name}, {len(az)} azimuths: {drums} ({report.elapsed():.2f} s)")


def _drums_say(facts: dict) -> str:
    """What the drums do to the gun's depression (``internal.envelope_summary``), in words."""
    gun = f"{facts['gun_min_deg']:.1f} deg"
    if not facts["fuel_drums"]:
        return f"no fuel drums fitted: the gun's own depression limit, {gun}, holds at every azimuth"
    if facts["worst_deg"] is None and not facts["blocked_deg"]:
        return f"the fuel drums never limit depression: the gun's own limit, {gun}, holds at every azimuth"
    text = []
    if facts["worst_deg"] is not None:
        text.append(f"the fuel drums limit depression over {facts['limited_deg']:.0f} deg of azimuth, to at "
                    f"worst {facts['worst_deg']:.2f} deg (gun limit {gun})")
    if facts["blocked_deg"]:
        text.append(f"over {facts['blocked_deg']:.0f} deg of azimuth even full elevation meets a drum")
    return "; ".join(text)
