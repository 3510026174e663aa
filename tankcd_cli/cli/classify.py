"""tankcd classify TERRAIN: mean curvature and region classes into a terrain store."""

from __future__ import annotations

import os

import click

from tankcd_cli import api
from tankcd_cli.cli.options import given, output_option, refuse_clashes, vehicle_option, verbosity_options
from tankcd_cli.errors import InputError
from tankcd_cli.io.atomic import atomic_path
from tankcd_cli.io.files import same_path
from tankcd_cli.io.h5 import is_hdf5
from tankcd_cli.io.heightmap import HeightmapSpec, parse_size
from tankcd_cli.names import CURVATURE_METHODS, UP_AXES
from tankcd_cli.plots import class_map_png, grid_map_png
from tankcd_cli.terrain.open import OptionError
from tankcd_cli.terrain.regions import Thresholds
from tankcd_cli.vehicle import vehicle_preset

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
              help="Input format when the suffix does not say (needed for stdin): obj, ply, stl, off, glb, asc, vtk, "
                   "vtu, png, raw, r16, r32, ...")
@vehicle_option
@click.option("--thresholds", nargs=2, type=float, default=None, metavar="FLAT UNEVEN",
              help="Class boundaries on footprint-averaged |H|, 1/m (default: derived from the vehicle's "
                   "track length; see README).")
@click.option("--png", type=click.Path(dir_okay=False, allow_dash=True), default=None,
              help="Also draw the class map and curvature map to this PNG (- for stdout, with -o FILE).")
@click.option("--crs", default=None, metavar="CRS",
              help="DEMs: the metric CRS to reproject to (EPSG:32633, a WKT or PROJ string); default: a "
                   "geographic DEM (or one whose projected metres stray over 1 % from ground metres, such as "
                   "EPSG:3857) goes to the UTM zone of its centre, another projected one stays as it is. "
                   "Heightmaps: the projected CRS --origin is in (default: none, a local grid).")
@click.option("--band", type=click.IntRange(min=1), default=None, help="DEMs: the raster band of the heights "
              "(needed when a raster has several); a colour PNG heightmap's channel.")
@click.option("--spacing", type=float, default=None, metavar="M",
              help="Heightmaps (PNG, RAW): the post spacing, m (required: the file does not say).")
@click.option("--z-scale", "z_scale", type=float, default=None, metavar="M",
              help="Heightmaps: metres per value step, positive: height = z-offset + z-scale x value (default 1).")
@click.option("--z-offset", "z_offset", type=float, default=None, metavar="M",
              help="Heightmaps: the height of value 0, m (default 0).")
@click.option("--z-range", "z_range", nargs=2, type=float, default=None, metavar="LOW HIGH",
              help="Heightmaps: the heights of values 0 and full scale (65535 in 16 bits, 255 in 8), m, instead of "
                   "--z-scale and --z-offset (Unity's terrain height: 0 HEIGHT).")
@click.option("--origin", nargs=2, type=float, default=None, metavar="X Y",
              help="Heightmaps: world x, y of the north-west post (the image's top-left pixel), m; default: the "
                   "south-west post at 0, 0.")
@click.option("--size", "raw_size", default=None, metavar="COLSxROWS",
              help="RAW heightmaps: columns x rows (default: square).")
@click.option("--tile", type=click.IntRange(min=16), default=512, show_default=True,
              help="DEMs: posts per tile side; memory grows with it, the result does not change.")
@click.option("--jobs", type=click.IntRange(min=1), default=None, help="DEMs: worker threads (default: the cores).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="DEMs: classify the tiles on this Dask cluster (tcp://host:8786); the workers read the DEM "
                   "from its path, which they must all see; this process writes the store.")
@verbosity_options
@click.pass_obj
def classify(report, terrain, output, method, up, fmt, vehicle_name, thresholds, png, crs, band, spacing, z_scale,
             z_offset, z_range, origin, raw_size, tile, jobs, scheduler):
    """Load TERRAIN (mesh, DEM or store), compute the signed mean curvature at every
    vertex, classify flat / general / uneven regions and write the terrain store.

    A DEM (any raster GDAL reads, a folder of tiles, an ESRI ASCII grid, a
    heightmap) is classified tile by tile into the grid layout, in memory that
    does not grow with the DEM. TERRAIN may be - for standard input (give --format).

    A heightmap (PNG, 8- or 16-bit grey; RAW: .raw or .r16 16-bit, .r32 float32,
    little-endian) needs --spacing; its row 0 (the image's top) is north, column
    0 west. Heights quantized in steps that would show as terraces in the classes
    warn, and the curvature is taken from heights smoothed within half a step.
    """
    if terrain != "-" and not os.path.exists(terrain):  # before -o's default is compared with it
        raise InputError(terrain, "no such file")
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
    heightmap = _heightmap_spec(spacing, z_scale, z_offset, z_range, origin, raw_size)
    _refuse_clashes(terrain, output, png, explicit)
    report.kernels()
    step = report.progress("classify")
    step(f"reading {terrain}")

    def on_grid(grid, info):
        report.detail(f"classify: {info.source}: {grid.rows:,} rows x {grid.cols:,} columns of posts, "
                      f"{grid.dx:g} m (x) x {grid.dy:g} m (y) apart, {grid.crs_name}"
                      + (f" (reprojected from {info.source_crs_name})" if info.reprojected else ""))
        for note in info.notes:
            report.detail(f"classify: {info.source}: {note}")

    def tile_progress(done, total, posts, seconds):
        report.bar(f"classify: tile {done}/{total}, {posts / max(seconds, 1e-9) / 1e6:.1f} M posts/s")

    def before_commit(tmp, done):
        if done.layout != "grid":
            return
        report.bar(None)
        if png:  # drawn from the store before it is renamed: a map that fails takes the store with it
            with atomic_path(png, ".png") as tmp_png:
                grid_map_png(tmp, tmp_png, title=done.source)

    try:
        ctx = click.get_current_context()
        done = api.classify(terrain, output, method=method, up=up, fmt=fmt, vehicle=vehicle_name,
                             thresholds=user_thresholds, crs=crs, band=band,
                             tile=tile if given(ctx, "tile") else None, jobs=jobs if given(ctx, "jobs") else None,
                             scheduler=scheduler, heightmap=heightmap,
                             progress=step, tile_progress=tile_progress, on_grid=on_grid, before_commit=before_commit)
    except OptionError as exc:
        raise click.UsageError(str(exc)) from None
    a = done.attrs
    if done.layout == "grid":
        g = done.grid
        if a["height_quantum"] and not a["quantum_filter_passes"]:
            report.detail(f"classify: heights quantized in steps of {a['height_quantum']:.3g} m: "
                          + ("too fine to show in the classes at these posts" if a["height_quantum_shows"]
                             else "the ground's own relief at the post scale is larger")
                          + "; classified as they are")
        report.info(f"classify: {done.source} -> {output}: {g.rows:,} rows x {g.cols:,} columns of posts "
                    f"({a['valid_posts']:,} with data), H by {done.method}; flat {a['share_flat']:.0%}, "
                    f"general {a['share_general']:.0%}, uneven {a['share_uneven']:.0%} of the area "
                    f"({report.elapsed():.2f} s)")
        return
    store = done.mesh_store
    if png:
        with atomic_path(png, ".png") as tmp:
            class_map_png(store, tmp)
    for key in ("merged_vertices", "unreferenced_vertices", "degenerate_faces", "repeated_faces"):
        report.detail(f"classify: {key.replace('_', ' ')}: {a[key]}")
    report.detail(f"classify: boundary vertices: {a['boundary_vertices']}, non-manifold vertices: {a['nonmanifold_vertices']}")
    report.info(f"classify: {done.source} -> {output}: {len(store.vertices):,} vertices, {len(store.faces):,} faces, "
                f"H by {done.method}; flat {a['share_flat']:.0%}, general {a['share_general']:.0%}, "
                f"uneven {a['share_uneven']:.0%} of the area ({report.elapsed():.2f} s)")


def _heightmap_spec(spacing, z_scale, z_offset, z_range, origin, raw_size):
    """The HeightmapSpec the heightmap options give, or None when none is given (their values
    are checked when the heightmap is read: a bad number is bad input, exit 3)."""
    size = None
    if raw_size is not None:
        try:
            size = parse_size(raw_size)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--size") from None
    spec = HeightmapSpec(spacing=spacing, z_scale=z_scale, z_offset=z_offset,
                         z_range=tuple(z_range) if z_range else None, origin=tuple(origin) if origin else None,
                         size=size)
    return spec if spec.given() else None


def _refuse_clashes(terrain, output, png, explicit):
    """No output may be the input or the other output; a store is rewritten in place only when
    -o names it (the new store is written beside it and replaces it when complete)."""
    in_place = terrain != "-" and same_path(output, terrain)
    if in_place and not (explicit and is_hdf5(terrain)):
        hint = " (to rewrite a store in place, name it with -o)" if is_hdf5(terrain) else ""
        raise click.UsageError(f"-o/--output {output} is also TERRAIN {terrain}: give -o another path{hint}")
    refuse_clashes({} if in_place else {"TERRAIN": terrain}, {"-o/--output": output, "--png": png})
    if png is not None and same_path(png, terrain):
        raise click.UsageError(f"--png {png} is also TERRAIN {terrain}: give another output path")

