"""tankcd classify TERRAIN: mean curvature and region classes into a terrain store."""

from __future__ import annotations

import os

import click

from tankcd_cli.cli.options import output_option, vehicle_option, verbosity_options

METHOD_HELP = ("Mean-curvature estimator: cotan (cotangent formula with mixed Voronoi area, the paper's "
               "equation 2; fastest), sphere (the paper's four-point sphere fit), jet ( "
               "quartic fit over the nearest 20 vertices; accurate on irregular meshes, slower).")


@click.command(short_help="Classify a terrain into an HDF5 store.")
@click.argument("terrain", type=click.Path(allow_dash=True))
@output_option("Output store (default: TERRAIN's stem + .h5 beside it; - for stdout).")
@click.option("--method", type=click.Choice(["cotan", "sphere", "jet"]), default="cotan", show_default=True,
              help=METHOD_HELP)
@click.option("--up", type=click.Choice(["z", "y"]), default="z", show_default=True,
              help="Up axis of the mesh; y-up meshes (most OBJ exports) are turned to z-up.")
@click.option("--format", "fmt", default=None, metavar="FMT",
              help="Input format when the suffix does not say (needed for stdin): obj, ply, stl, off, glb, asc, vtk, vtu, ...")
@vehicle_option
@click.option("--thresholds", nargs=2, type=float, default=None, metavar="FLAT UNEVEN",
              help="Class boundaries on footprint-averaged |H|, 1/m (default: derived from the vehicle's "
                   "track length; see README).")
@click.option("--png", type=click.Path(dir_okay=False), default=None,
              help="Also draw the class map and curvature map to this PNG.")
@verbosity_options
@click.pass_obj
def classify(report, terrain, output, method, up, fmt, vehicle_name, thresholds, png):
    """Load TERRAIN (mesh, DEM or store), compute the signed mean curvature at every
    vertex, classify flat / general / uneven regions and write the terrain store.

    TERRAIN may be - for standard input (give --format).
    """
    from tankcd_cli.io.atomic import atomic_path
    from tankcd_cli.terrain.classify import classify_terrain, load_terrain
    from tankcd_cli.terrain.regions import Thresholds
    from tankcd_cli.terrain.store import write_store
    from tankcd_cli.vehicle import vehicle_preset

    if output is None:
        if terrain == "-":
            raise click.UsageError("reading from stdin needs -o/--output")
        output = os.path.splitext(terrain)[0] + ".h5"
    user_thresholds = None
    if thresholds is not None:
        try:
            user_thresholds = Thresholds(thresholds[0], thresholds[1], derivation="given with --thresholds")
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--thresholds") from None
    step = report.progress("classify")
    step(f"reading {terrain}")
    raw = load_terrain(terrain, up=up, fmt=fmt)
    store = classify_terrain(raw, method=method, vehicle=vehicle_preset(vehicle_name),
                             thresholds=user_thresholds, progress=step)
    step(f"writing {output}")
    with atomic_path(output, ".h5") as tmp:
        write_store(tmp, store)
    if png:
        from tankcd_cli.plots import class_map_png

        with atomic_path(png, ".png") as tmp:
            class_map_png(store, tmp)
    a = store.attrs
    for key in ("merged_vertices", "unreferenced_vertices", "degenerate_faces", "repeated_faces"):
        report.detail(f"classify: {key.replace('_', ' ')}: {a[key]}")
    report.detail(f"classify: boundary vertices: {a['boundary_vertices']}, non-manifold vertices: {a['nonmanifold_vertices']}")
    report.info(f"classify: {raw.source} -> {output}: {len(store.vertices):,} vertices, {len(store.faces):,} faces, "
                f"H by {method}; flat {a['share_flat']:.0%}, general {a['share_general']:.0%}, "
                f"uneven {a['share_uneven']:.0%} of the area ({report.elapsed():.2f} s)")
