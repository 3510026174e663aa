"""tankcd info FILE: describe a terrain store."""

from __future__ import annotations

import json

import click

from tankcd_cli.cli.options import verbosity_options


@click.command(short_help="Describe a store.")
@click.argument("file", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON on stdout.")
@verbosity_options
@click.pass_obj
def info(report, file, as_json):
    """Describe FILE: a terrain store written by classify (source, counts,
    extent, curvature method, thresholds, area share of each class), a tree
    written by bvh (depth, node counts per level and type, leaf sizes, bounds),
    or a scene: every file it names is read as replay reads it (a file replay
    cannot read fails here too, exit 3) and each obstacle is shown placed
    (position, angles, scale, triangles, world bounds, whether it lies over
    the terrain), with the effects the scene enables.

    --json prints the same facts as one JSON object with snake_case keys."""
    from tankcd_cli.describe import describe_store

    facts = describe_store(file)
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
        label = f"{indent}{_label(key)}:"
        if isinstance(value, dict) and (_nested(value) or len(_fmt(value)) > INLINE):
            out.append(label)
            out += _lines(value, indent + "  ")
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            out.append(label)
            for i, item in enumerate(value):
                out.append(f"{indent}  {_label(str(item.get('name', i + 1)))}:")
                out += _lines({k: v for k, v in item.items() if k != "name"}, indent + "    ")
        else:
            text = NONE_TEXT.get(key, "none") if value is None else _fmt(value)
            out.append(f"{label:<{WIDTH}}{text}" if len(label) < WIDTH else f"{label} {text}")
    return out


# what a null fact means, in the text output
NONE_TEXT = {"up": "the format's convention", "on_terrain": "unknown (no terrain)",
             "mesh": "none (generated from the preset's dimensions)", "path": "none"}


def _nested(value: dict) -> bool:
    return any(isinstance(v, dict) or (isinstance(v, list) and any(isinstance(x, (dict, list)) for x in v))
               for v in value.values())


def _label(key: str) -> str:
    return key.replace("_", " ")


def _fmt(value) -> str:
    if value is None:
        return "none"
    if isinstance(value, float):
        return f"{value:.10g}"  # UTM northings keep their metres
    if isinstance(value, (list, tuple)):
        return ", ".join(_fmt(v) for v in value)
    if isinstance(value, dict):
        return ", ".join(f"{_label(k)} " + (f"[{_fmt(v)}]" if isinstance(v, (list, tuple)) else _fmt(v))
                         for k, v in value.items())
    from tankcd_cli.errors import printable

    return printable(str(value))
