"""Options shared by several commands."""

from __future__ import annotations

import click

from tankcd_cli.names import PRESET_NAMES as VEHICLE_PRESETS


def vehicle_option(f):
    return click.option("--vehicle", "vehicle_name", type=click.Choice(VEHICLE_PRESETS), default="t72",
                        show_default=True, help="Vehicle preset whose footprint sizes the region classes.")(f)


def output_option(help_text: str):
    def deco(f):
        return click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True), default=None,
                            help=help_text)(f)
    return deco


QUIET_HELP = "Only warnings and errors on stderr (no progress, no closing report line)."
VERBOSE_HELP = "More detail on stderr (repeatable); tracebacks on errors."


def set_verbosity(ctx, verbose: int = 0, quiet: bool = False) -> None:
    """-v and -q wherever given (before or after the command name): -q with -v is a usage error."""
    meta = ctx.meta
    if verbose:
        meta["tankcd.verbose"] = meta.get("tankcd.verbose", 0) + verbose
    if quiet:
        meta["tankcd.quiet"] = True
    if meta.get("tankcd.verbose") and meta.get("tankcd.quiet"):
        raise click.UsageError("-q/--quiet and -v/--verbose contradict each other: give one of them")
    if ctx.obj is not None:
        ctx.obj.verbosity = -1 if meta.get("tankcd.quiet") else meta.get("tankcd.verbose", 0)


def verbosity_options(f):
    """-v/-q/--strict after the command name too (``tankcd classify x.obj -v``)."""
    def set_verbose(ctx, param, value):
        if value:
            set_verbosity(ctx, verbose=value)
        return value

    def set_quiet(ctx, param, value):
        if value:
            set_verbosity(ctx, quiet=True)
        return value

    f = click.option("-v", "--verbose", count=True, expose_value=False, callback=set_verbose,
                     help=VERBOSE_HELP)(f)
    f = strict_option(f)
    return click.option("-q", "--quiet", is_flag=True, expose_value=False, callback=set_quiet,
                        help=QUIET_HELP)(f)


STRICT_HELP = "Treat warnings (likely set-up slips) as bad input: exit 3, write nothing."


def set_strict(ctx, param, value):
    """Warnings become errors for the rest of this invocation (the group restores the filters)."""
    if value:
        import warnings

        from tankcd_cli.errors import SetupWarning

        ctx.meta["tankcd.strict"] = True  # for the group, which sets the filters after parsing its options
        warnings.simplefilter("error", SetupWarning)
    return value


def strict_option(f):
    return click.option("--strict", is_flag=True, expose_value=False, callback=set_strict, help=STRICT_HELP)(f)


def refuse_clashes(inputs: dict, outputs: dict) -> None:
    """Exit 2 (a usage error naming both) when an output is an input or another output.

    inputs, outputs : option label -> path (None and "-" are skipped). Paths are compared
    resolved (symbolic links, ``..``) and, where both exist, as files (hard links too).
    """
    from tankcd_cli.io.files import same_path

    seen = [(label, path) for label, path in inputs.items() if path not in (None, "-")]
    for label, path in outputs.items():
        if path in (None, "-"):
            continue
        for other_label, other in seen:
            if same_path(path, other):
                raise click.UsageError(f"{label} {path} is also {other_label} {other}: give another output path")
        seen.append((label, path))


def scene_inputs(scene) -> dict:
    """The files a loaded scene reads, labelled for ``refuse_clashes``."""
    files = {"the scene's terrain": scene.terrain_path, "the scene's vehicle mesh": scene.vehicle_mesh}
    for ob in scene.obstacles:
        files[f"obstacle {ob.name!r}"] = ob.path
    return files
