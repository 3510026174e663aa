"""Options shared by several commands."""

from __future__ import annotations

import click

VEHICLE_PRESETS = ("t72", "t55", "m1")


def vehicle_option(f):
    return click.option("--vehicle", "vehicle_name", type=click.Choice(VEHICLE_PRESETS), default="t72",
                        show_default=True, help="Vehicle preset whose footprint sizes the region classes.")(f)


def output_option(help_text: str):
    def deco(f):
        return click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True), default=None,
                            help=help_text)(f)
    return deco


def verbosity_options(f):
    """-v/-q after the command name too (``tankcd classify x.obj -v``)."""
    def set_verbose(ctx, param, value):
        if value and ctx.obj is not None:
            ctx.obj.verbosity = max(ctx.obj.verbosity, 0) + value
        return value

    def set_quiet(ctx, param, value):
        if value and ctx.obj is not None:
            ctx.obj.verbosity = -1
        return value

    f = click.option("-v", "--verbose", count=True, expose_value=False, callback=set_verbose,
                     help="More detail on stderr.")(f)
    return click.option("-q", "--quiet", is_flag=True, expose_value=False, callback=set_quiet,
                        help="Only errors on stderr.")(f)
