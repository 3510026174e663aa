"""tankcd envelope: the lowest safe gun elevation at every turret azimuth."""

from __future__ import annotations

import click

from tankcd_cli.cli.options import VEHICLE_PRESETS, refuse_clashes, verbosity_options


@click.command(short_help="Lowest safe gun elevation per turret azimuth (CSV; --png polar plot).")
@click.option("--scene", type=click.Path(), default=None, help="Take the vehicle from this scene.")
@click.option("--vehicle", "vehicle_name", type=click.Choice(VEHICLE_PRESETS), default="t72", show_default=True,
              help="Vehicle preset (without --scene).")
@click.option("--step", "step_deg", type=click.FloatRange(0.01, 90), default=1.0, show_default=True,
              help="Azimuth step, degrees.")
@click.option("--method", type=click.Choice(["exact", "projection"]), default="exact", show_default=True,
              help="exact cylinder test, or the paper's two-plane projection (conservative).")
@click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True), default="-", show_default=True,
              help="CSV output (- for stdout).")
@click.option("--png", type=click.Path(dir_okay=False), default=None, help="Also draw a polar plot.")
@verbosity_options
@click.pass_obj
def envelope(report, scene, vehicle_name, step_deg, method, output, png):
    """For every turret azimuth (0 = forward, counter-clockwise), the lowest gun elevation at
    which the barrel clears the rear fuel drums, to 0.01 degree (bisection on the exact test).
    Columns: azimuth_deg, min_elevation_deg (empty where even full elevation touches), limited_by
    (the drum that sets the limit, or "gun" where the gun's own depression limit does), checked
    (every elevation above the limit was tested clear on a 0.25 degree grid)."""
    import numpy as np

    from tankcd_cli.collision.internal import DRUMS, elevation_envelope
    from tankcd_cli.io.atomic import atomic_path, output_text
    from tankcd_cli.vehicle import vehicle_preset

    refuse_clashes({"--scene": scene}, {"-o/--output": output, "--png": png})
    if scene:
        from tankcd_cli.scene import load_scene

        vehicle = load_scene(scene).vehicle
    else:
        vehicle = vehicle_preset(vehicle_name)
    az = np.arange(0.0, 360.0 - 1e-9, step_deg)
    env = elevation_envelope(vehicle, az, method=method)
    lines = ["azimuth_deg,min_elevation_deg,limited_by,checked\n"]
    for a, e, lim, who, ok in zip(env["azimuth"], env["min_elevation"], env["limited"], env["blocked_by"], env["checked"]):
        by = DRUMS[who] if (lim or not np.isfinite(e)) and who >= 0 else "gun"
        lines.append(f"{a:.3f},{'' if not np.isfinite(e) else f'{e:.2f}'},{by},{str(bool(ok)).lower()}\n")
    text = "".join(lines)
    with output_text(output, ".csv") as fh:
        fh.write(text)
    if png:
        from tankcd_cli.plots import envelope_png

        with atomic_path(png, ".png") as tmp:
            envelope_png(vehicle, env, tmp)
    limited = env["limited"]
    worst = np.nanmax(env["min_elevation"][limited]) if limited.any() else vehicle.gun_min_deg
    report.info(f"envelope: {vehicle.name}, {len(az)} azimuths: drums limit depression over "
                f"{limited.sum() * step_deg:.0f} deg of azimuth, to at worst {worst:.2f} deg "
                f"(gun limit {vehicle.gun_min_deg:.1f} deg) ({report.elapsed():.2f} s)")
