"""tankcd info FILE: describe any file tankcd reads or writes."""

from __future__ import annotations

import json

import click

from tankcd_cli.cli.options import verbosity_options
from tankcd_cli.describe import describe_store
from tankcd_cli.errors import printable
from tankcd_cli.io.trajectory.formats import FAMILIES


def _a_file(ctx, param, value):
    if value == "-":
        raise click.BadParameter("info reads a file (a store is read in place, a scene's paths are relative to "
                                 "it), not standard input", ctx=ctx, param=param)
    return value


INFO_HELP = """Describe FILE: a terrain store written by classify (source, counts,
    extent, curvature method, thresholds, area share of each class), a tree
    written by bvh (depth, node counts per level and type, leaf sizes, bounds),
    a scene: every file it names is read as replay reads it (a file replay
    cannot read fails here too, exit 3) and each obstacle is shown placed
    (position, angles, scale, triangles, world bounds, whether it lies over
    the terrain), with the effects the scene enables; or a trajectory
    ({families}): its rows, time span and entities (rows or updates,
    time span, pieces of motion; with --scene, the vehicle each is), and
    what was skipped.

    A raw terrain is described without classifying it (nothing is written):
    a DEM raster (GeoTIFF, ESRI ASCII, ...: size, CRS, post spacing, extent,
    its NODATA share and heights from a bounded sample), a heightmap (PNG,
    RAW: size, bits, values, and the options classify needs) or a mesh
    (vertices, faces, bounds, parts). What replay writes: events (JSON Lines:
    events per kind, the share between rows, the time span, the obstacles,
    parts and entities named), poses and events as Parquet (rows, row groups,
    columns, the metadata: CRS, options, sources with their SHA-256, tankcd's
    version; the same counts), a replay summary (its fields and warnings) and
    fleet.json (trajectories ok and failed, rows, collisions, the world). A
    file that is none of these, or that its reader refuses, exits 3 with one
    line naming it.

    Every pair says its order: "161 rows x 241 columns", "0.24 km (x) x 0.16 km (y)",
    "x 500000, y 4500160", "500000 to 500240".

    --json prints the same facts as one JSON object with snake_case keys: points, sizes
    and spacings as [x, y] or [x, y, z], extents as [min, max], bounds as {min, max},
    grid shapes as {rows, columns}, area shares as fractions from 0 to 1
    (area_fraction_flat, ...)."""  # {families}: the trajectory inputs, as their registry names them


@click.command(short_help="Describe any file tankcd reads or writes (stores, terrains, outputs).",
               help=INFO_HELP.replace("{families}", ", ".join(FAMILIES)))
@click.argument("file", type=click.Path(allow_dash=True), callback=_a_file)
@click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON on stdout.")
@click.option("--scene", type=click.Path(), default=None,
              help="With a trajectory: which vehicle of this scene each entity is.")
@verbosity_options
@click.pass_obj
def info(report, file, as_json, scene):
    """``tankcd info`` (its help: ``INFO_HELP``)."""
    facts = describe_store(file, scene)
    if as_json:
        click.echo(json.dumps(facts, indent=2, default=_plain))
        return
    for line in _lines(facts):
        click.echo(line)


WIDTH = 22  # the label column
INLINE = 100  # a dict of plain values up to this many characters goes on one line


def _plain(value):
    """numpy scalars and arrays as JSON takes them."""
    tolist = getattr(value, "tolist", None)
    return tolist() if tolist is not None else float(value)


def _lines(facts: dict, indent: str = "") -> list[str]:
    """Readable text: one "label: value" line a fact (labels spelled with spaces); nested
    objects and lists of objects (obstacles) as indented blocks."""
    out = []
    for key, value in facts.items():
        if key in JSON_ONLY:
            continue
        label = f"{indent}{_label(key)}:"
        if isinstance(value, dict) and key in NAMED and len(_fmt(value, key)) > INLINE:
            out.append(label)  # many names (entities): one a line, spelled as the file has them
            out += [f"{indent}  {_fmt(k)}: {_fmt(v)}" for k, v in value.items()]
        elif isinstance(value, dict) and not _pair(key, value) and (_nested(value) or len(_fmt(value)) > INLINE):
            out.append(label)
            out += _lines(value, indent + "  ")
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            out.append(label)
            for i, item in enumerate(value):
                by = next((k for k in ITEM_LABELS if isinstance(item.get(k), str)), None)
                name = str(item[by]) if by else str(i + 1)
                out.append(f"{indent}  {_fmt(name) if by == 'trajectory' else _label(name)}:")
                out += _lines({k: v for k, v in item.items() if k != by}, indent + "    ")
        elif isinstance(value, list) and value and all(isinstance(v, str) for v in value) \
                and any(len(v) > INLINE // 3 for v in value):  # long texts (warnings): one a line
            out.append(label)
            out += [f"{indent}  - {_fmt(v)}" for v in value]
        else:
            text = NONE_TEXT.get(key, "none") if value is None else _fmt(value, key)
            out.append(f"{label:<{WIDTH}}{text}" if len(label) < WIDTH else f"{label} {text}")
    return out


# what a null fact means, in the text output
JSON_ONLY = {"crs_wkt"}  # facts too long for a line of text (the text names the CRS)
# dicts keyed by the file's own names (obstacles, parts, entities), shown as they are spelled
NAMED = {"obstacles", "parts", "entities", "status", "channels"}
ITEM_LABELS = ("name", "trajectory", "role")  # what labels an item of a list of objects, the first it has
NONE_TEXT = {"up": "the format's convention", "on_terrain": "unknown (no terrain)",
             "time_origin": "none (relative times)",
             "nodata_value": "none (every post a height)", "extent_z": "none (no heights read)",
             "mesh": "none (generated from the preset's dimensions)", "path": "none",
             "dem_grid_posts": "none (an irregular mesh)"}
# every pair says its order: sizes and spacings as "A unit (x) x B unit (y)"; the label loses the unit
SIZES = {"size_km": ("size", "km"), "post_spacing": ("post spacing", "m")}
POINTS = {"north_west_post", "position", "scale"}  # "x A, y B(, z C)"
AXES = "xyz"


def _nested(value: dict) -> bool:
    return any(isinstance(v, dict) or (isinstance(v, list) and any(isinstance(x, (dict, list)) for x in v))
               for v in value.values())


def _label(key: str) -> str:
    if key in SIZES:
        return SIZES[key][0]
    if key.startswith("area_fraction_"):  # a fraction in JSON, a percentage here
        return "area " + key.removeprefix("area_fraction_")
    if key.endswith("_fraction"):
        return key.removesuffix("_fraction").replace("_", " ") + " share"
    return key.replace("_", " ")


def _pair(key: str, value) -> str | None:
    """A pair or triple in words that say its order, or None if ``value`` is not one."""
    if isinstance(value, dict) and set(value) == {"rows", "columns"}:
        return f"{_fmt(value['rows'])} rows x {_fmt(value['columns'])} columns"
    if isinstance(value, dict) and set(value) == {"min", "max"} and _numbers(value["min"]) \
            and _numbers(value["max"]) and len(value["min"]) == len(value["max"]) <= 3:
        return ", ".join(f"{a} {_fmt(lo)} to {_fmt(hi)}" for a, lo, hi in zip(AXES, value["min"], value["max"]))
    if not _numbers(value):
        return None
    if key.startswith("extent_") and len(value) == 2:
        return f"{_fmt(value[0])} to {_fmt(value[1])}"
    if key in SIZES and len(value) == 2:
        unit = SIZES[key][1]
        return f"{_fmt(value[0])} {unit} (x) x {_fmt(value[1])} {unit} (y)"
    if key in POINTS and len(value) <= 3:
        return ", ".join(f"{a} {_fmt(v)}" for a, v in zip(AXES, value))
    if key == "nodes_per_level":
        return f"{_fmt(value)} (from the root down)"
    return None


def _numbers(value) -> bool:
    return isinstance(value, (list, tuple)) and bool(value) and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)


def _fmt(value, key: str = "") -> str:
    if value is None:
        return "none"
    pair = _pair(key, value)
    if pair is not None:
        return pair
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if key.startswith("area_fraction_") or key.endswith("_fraction"):
            return f"{value:.1%}"
        return f"{value:.10g}"  # UTM northings keep their metres
    if isinstance(value, (dict, list, tuple)) and not value:
        return "none"
    if isinstance(value, (list, tuple)):
        return ", ".join(_fmt(v) for v in value)
    if isinstance(value, dict) and key in NAMED:
        return ", ".join(f"{_fmt(k)} {_fmt(v)}" for k, v in value.items())
    if isinstance(value, dict):
        return ", ".join(f"{_label(k)} " + (f"[{_fmt(v, k)}]" if isinstance(v, (list, tuple)) else _fmt(v, k))
                         for k, v in value.items())
    return printable(str(value))
