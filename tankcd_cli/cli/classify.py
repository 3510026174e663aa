"""tankcd classify TERRAIN: mean curvature and region classes into a terrain store."""

from __future__ import annotations

import os

import click

from tankcd_cli.cli.options import output_option, vehicle_option, verbosity_options
from tankcd_cli.names import AUTO_METHODS, CURVATURE_METHODS, UP_AXES

METHOD_HELP = ("Mean-curvature estimator: auto (the default: grid on a DEM, jet on a mesh), grid (DEMs only: "
               "central differences over the 3 x 3 posts), cotan (cotangent formula with mixed Voronoi area, "
               "the paper's equation 2; does not converge on irregular meshes), sphere (the paper's four-point "
               "sphere fit), jet (quartic fit over the nearest 20 vertices; accurate on irregular meshes).")


@click.command(short_help="Classify a terrain into an HDF5 store.")
@click.argument("terrain", type=click.Path(allow_dash=True))
@output_option("Output store (default: TERRAIN's stem + .h5 beside it; - for stdout).")
@click.option("--method", type=click.Choice(("auto", "grid") + CURVATURE_METHODS), default="auto",
              help=METHOD_HELP)
@click.option("--up", type=click.Choice(UP_AXES), default=None,
              help="Up axis of the mesh; y-up meshes are turned to z-up (default: the format's convention, "
                   "y for glTF and GLB, z for the rest).")
@click.option("--format", "fmt", default=None, metavar="FMT",
              help="Input format when the suffix does not say (needed for stdin): obj, ply, stl, off, glb, asc, vtk, vtu, ...")
@vehicle_option
@click.option("--thresholds", nargs=2, type=float, default=None, metavar="FLAT UNEVEN",
              help="Class boundaries on footprint-averaged |H|, 1/m (default: derived from the vehicle's "
                   "track length; see README).")
@click.option("--png", type=click.Path(dir_okay=False), default=None,
              help="Also draw the class map and curvature map to this PNG.")
@click.option("--crs", default=None, metavar="CRS",
              help="DEMs: the metric CRS to reproject to (EPSG:32633, a WKT or PROJ string); default: a "
                   "geographic DEM goes to the UTM zone of its centre, a projected one stays as it is.")
@click.option("--band", type=click.IntRange(min=1), default=None, help="DEMs: the raster band of the heights "
              "(needed when a raster has several).")
@click.option("--tile", type=click.IntRange(min=16), default=512, show_default=True,
              help="DEMs: posts per tile side; memory grows with it, the result does not change.")
@click.option("--jobs", type=click.IntRange(min=1), default=None, help="DEMs: worker threads (default: the cores).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="DEMs: classify the tiles on this Dask cluster (tcp://host:8786); the workers read the DEM "
                   "from its path, which they must all see; this process writes the store.")
@verbosity_options
@click.pass_obj
def classify(report, terrain, output, method, up, fmt, vehicle_name, thresholds, png, crs, band, tile, jobs,
             scheduler):
    """Load TERRAIN (mesh, DEM or store), compute the signed mean curvature at every
    vertex, classify flat / general / uneven regions and write the terrain store.

    A DEM (any raster GDAL reads, a folder of tiles, an ESRI ASCII grid) is
    classified tile by tile into the grid layout, in memory that does not grow
    with the DEM. TERRAIN may be - for standard input (give --format).
    """
    from tankcd_cli.io.atomic import atomic_path
    from tankcd_cli.terrain.mesh.classify import classify_mesh, load_terrain
    from tankcd_cli.terrain.regions import Thresholds
    from tankcd_cli.terrain.mesh.store import write_mesh_store
    from tankcd_cli.vehicle import vehicle_preset

    explicit = output is not None
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
    _refuse_clashes(terrain, output, png, explicit)
    report.kernels()
    step = report.progress("classify")
    step(f"reading {terrain}")
    from tankcd_cli.terrain.grid.sources import open_dem

    dem = open_dem(terrain, fmt=fmt, band=band, crs=crs)
    if dem is not None:
        if up not in (None, "z"):
            raise click.UsageError("--up y makes no sense for a DEM (grids are z-up)")
        spec = None
        if scheduler:
            if terrain == "-":
                raise click.UsageError("--scheduler needs a DEM path the workers can read, not standard input")
            spec = (os.path.abspath(terrain), fmt, band, crs)
        method = AUTO_METHODS["dem"] if method == "auto" else method
        _classify_dem(report, dem, output, method, vehicle_preset(vehicle_name), user_thresholds, tile, jobs, png,
                      scheduler, spec)
        return
    if scheduler:
        raise click.UsageError("--scheduler applies to DEMs; a mesh is classified in this process")
    if crs or band:
        raise click.UsageError("--crs and --band apply to DEM rasters; meshes keep their coordinates")
    if method == "grid":
        raise click.UsageError("--method grid needs a DEM; meshes take cotan, sphere or jet")
    method = AUTO_METHODS["mesh"] if method == "auto" else method
    raw = load_terrain(terrain, up=up, fmt=fmt)
    store = classify_mesh(raw, method=method, vehicle=vehicle_preset(vehicle_name),
                          thresholds=user_thresholds, progress=step)
    step(f"writing {output}")
    with atomic_path(output, ".h5") as tmp:
        write_mesh_store(tmp, store)
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


def _classify_dem(report, dem, output, method, vehicle, thresholds, tile, jobs, png, scheduler=None, spec=None):
    from tankcd_cli.io.atomic import atomic_path
    from tankcd_cli.terrain.grid.classify import classify_dem

    grid, info = dem.grid, dem.info
    report.detail(f"classify: {info.source}: {grid.rows:,} x {grid.cols:,} posts at {grid.dx:g} x "
                  f"{grid.dy:g} m, {grid.crs_name}"
                  + (f" (reprojected from {info.source_crs_name})" if info.reprojected else ""))

    def progress(done, total, posts, seconds):
        report.bar(f"classify: tile {done}/{total}, {posts / max(seconds, 1e-9) / 1e6:.1f} M posts/s")

    with dem, atomic_path(output, ".h5") as tmp:
        a = classify_dem(dem, tmp, method=method, vehicle=vehicle, thresholds=thresholds, tile=tile, jobs=jobs,
                         progress=progress, scheduler=scheduler, spec=spec)
        report.bar(None)
        if png:
            from tankcd_cli.plots import grid_map_png

            with atomic_path(png, ".png") as tmp_png:
                grid_map_png(tmp, tmp_png, title=info.source)
    report.info(f"classify: {info.source} -> {output}: {grid.rows:,} x {grid.cols:,} posts "
                f"({a['valid_posts']:,} with data), H by {method}; flat {a['share_flat']:.0%}, "
                f"general {a['share_general']:.0%}, uneven {a['share_uneven']:.0%} of the area "
                f"({report.elapsed():.2f} s)")


def _refuse_clashes(terrain, output, png, explicit):
    """No output may be the input or the other output; a store is rewritten in place only when
    -o names it (the new store is written beside it and replaces it when complete)."""
    from tankcd_cli.cli.options import refuse_clashes
    from tankcd_cli.io.files import same_path
    from tankcd_cli.terrain.store import is_hdf5

    in_place = terrain != "-" and same_path(output, terrain)
    if in_place and not (explicit and is_hdf5(terrain)):
        hint = " (to rewrite a store in place, name it with -o)" if is_hdf5(terrain) else ""
        raise click.UsageError(f"-o/--output {output} is also TERRAIN {terrain}: give -o another path{hint}")
    refuse_clashes({} if in_place else {"TERRAIN": terrain}, {"-o/--output": output, "--png": png})
    if png is not None and same_path(png, terrain):
        raise click.UsageError(f"--png {png} is also TERRAIN {terrain}: give another output path")

