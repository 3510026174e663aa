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
    written by bvh (depth, node counts per level and type, leaf sizes), or a
    scene (the resolved scene and the effects it enables)."""
    from tankcd_cli.terrain.describe import describe_store

    facts = describe_store(file)
    if as_json:
        click.echo(json.dumps(facts, indent=2, default=float))
        return
    for key, value in facts.items():
        click.echo(f"{key + ':':<22}{_fmt(value)}")


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.10g}"  # UTM northings keep their metres
    if isinstance(value, (list, tuple)):
        return ", ".join(_fmt(v) for v in value)
    if isinstance(value, dict):
        return ", ".join(f"{k} {_fmt(v)}" for k, v in value.items())
    from tankcd_cli.errors import printable

    return printable(str(value))
