"""Options shared by several commands, and the checks that refuse what cannot apply (exit 2)."""

from __future__ import annotations

import os
from typing import NamedTuple

import click

from tankcd_cli.names import PRESET_NAMES as VEHICLE_PRESETS

VEHICLE_HELP = "Vehicle preset whose footprint sizes the region classes."
REPLAY_VEHICLE_HELP = ("Vehicle preset replayed, with --terrain (a scene's [vehicle] table decides with --scene); "
                       "its footprint also sizes the classes of a terrain classified on the fly.")


def vehicle_option(f=None, help_text: str = VEHICLE_HELP):
    """--vehicle PRESET; ``@vehicle_option`` or ``@vehicle_option(help_text=...)``."""
    def deco(g):
        return click.option("--vehicle", "vehicle_name", type=click.Choice(VEHICLE_PRESETS), default="t72",
                            show_default=True, help=help_text)(g)
    return deco(f) if f is not None else deco


def output_option(help_text: str):
    def deco(f):
        return click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True), default=None,
                            help=help_text)(f)
    return deco


QUIET_HELP = "Only errors on stderr (no warnings, progress or closing report line; --strict still fails on a warning)."
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


def no_parquet(instead: str, reading: bool = False):
    """An option callback: a path ending in .parquet is a usage error where Parquet is not read or
    written (replay writes it; collide does not read it); ``instead`` is the suffix to give."""
    def check(ctx, param, value):
        for path in value if isinstance(value, (tuple, list)) else (value,):
            if isinstance(path, str) and path.lower().endswith(".parquet"):
                what = "input" if reading else "output"
                raise click.BadParameter(f"{path}: Parquet {what} is not supported yet; "
                                         f"{'give' if reading else 'write'} {instead}", ctx=ctx, param=param)
        return value
    return check


def no_stdin(ctx, param, value):
    """An option callback for a scene: - (standard input) is a usage error, since the paths a scene
    names are relative to the scene's own file."""
    if value == "-":
        raise click.BadParameter("a scene is read from a file (the paths it names are relative to it), not from "
                                 "standard input", ctx=ctx, param=param)
    return value


def no_dash_directory(ctx, param, value):
    """An option callback for an output directory: - (standard output) is a usage error, not a
    directory named '-'."""
    if value == "-":
        raise click.BadParameter("several files go into this directory: give a directory, not - (standard "
                                 "output)", ctx=ctx, param=param)
    return value


def refuse_clashes(inputs: dict, outputs: dict) -> None:
    """Exit 2 (a usage error naming both) when an output is an input or another output, or when
    two outputs are standard output (-).

    inputs, outputs : option label -> path (None is skipped; "-" only counts as standard output).
    Paths are compared resolved (symbolic links, ``..``) and, where both exist, as files (hard
    links too). Outputs may share a character device (``--poses /dev/null --events /dev/null``:
    written in place, neither replaces the other).
    """
    from tankcd_cli.io.files import is_character_device, same_path

    seen = [(label, path) for label, path in inputs.items() if path not in (None, "-")]
    to_stdout = [label for label, path in outputs.items() if path == "-"]
    if len(to_stdout) > 1:
        raise click.UsageError(f"{to_stdout[0]} and {to_stdout[1]} both go to standard output (-): give one of them "
                               "a file")
    for label, path in outputs.items():
        if path in (None, "-"):
            continue
        for other_label, other in seen:
            if same_path(path, other) and not (other_label in outputs and is_character_device(path)):
                raise click.UsageError(f"{label} {path} is also {other_label} {other}: give another output path")
        seen.append((label, path))


def scene_inputs(scene) -> dict:
    """The files a loaded scene reads, labelled for ``refuse_clashes``."""
    files = {"the scene's terrain": scene.terrain_path, "the scene's vehicle mesh": scene.vehicle_mesh}
    for ob in scene.obstacles:
        files[f"obstacle {ob.name!r}"] = ob.path
    return files


# Options that only make sense with (or without) another. A rule names options by their
# parameter names; a name that is not a parameter is a condition the command passes in
# (``conditions``), labelled by the text given there.
class Needs(NamedTuple):
    """``option`` given without ``needed``: a usage error, ``why`` saying what option is for."""

    option: str
    needed: str
    why: str


class Excludes(NamedTuple):
    """``option`` given with ``other``: a usage error, ``why`` saying what decides instead."""

    option: str
    other: str
    why: str


class Refused(NamedTuple):
    """``option`` given with any of ``others`` (or alone, ``others`` empty): a usage error saying
    ``message`` as it is."""

    option: str
    others: tuple
    message: str


class OneOf(NamedTuple):
    """Not exactly one of ``options`` given: a usage error saying ``message``."""

    options: tuple
    message: str


class Positive(NamedTuple):
    """``option``'s value, when given, a positive finite number, else bad input (exit 3, one line
    naming the option): NaN and infinity pass click's ``FloatRange`` and would reach the work.
    ``what`` says what the number is."""

    option: str
    what: str


def check_option_values(ctx: click.Context, rules) -> None:
    """Exit 3 (``InputError``: one line naming the option and the value) at the first ``Positive``
    rule a given value breaks."""
    import math

    from tankcd_cli.errors import InputError

    for rule in rules:
        value = ctx.params.get(rule.option)
        if isinstance(rule, Positive) and value is not None and not (math.isfinite(value) and value > 0):
            raise InputError(option_label(ctx, rule.option), f"{value!r} is not {rule.what}: give a positive finite "
                                                             "number")


def given(ctx: click.Context, name: str) -> bool:
    """Whether the user gave parameter ``name`` (on the command line), not left it at its default."""
    from click.core import ParameterSource

    return ctx.get_parameter_source(name) in (ParameterSource.COMMANDLINE, ParameterSource.ENVIRONMENT,
                                              ParameterSource.PROMPT)


def option_label(ctx: click.Context, name: str) -> str:
    """How the help spells parameter ``name``: ``-o/--output``, ``--png-colour``, ``MODEL``."""
    for param in ctx.command.params:
        if param.name == name:
            if isinstance(param, click.Argument):
                return param.human_readable_name
            opts = [o for o in param.opts if o.startswith("--")] or list(param.opts)
            shorts = [o for o in param.opts if not o.startswith("--")]
            return "/".join(shorts + opts)
    return name


def check_option_combinations(ctx: click.Context, rules, conditions: dict | None = None) -> None:
    """Exit 2 (a usage error naming both) at the first rule the given options break.

    conditions : label -> bool, for rules that depend on more than one option having been given
    (``{"fleet mode (--out-dir)": True}``); a rule names a condition by its label.
    """
    conditions = conditions or {}

    def holds(name: str) -> bool:
        return bool(conditions[name]) if name in conditions else given(ctx, name)

    def label(name: str) -> str:
        return name if name in conditions else option_label(ctx, name)

    for rule in rules:
        if isinstance(rule, OneOf):
            if sum(holds(name) for name in rule.options) != 1:
                raise click.UsageError(rule.message)
            continue
        if not holds(rule.option):
            continue
        if isinstance(rule, Refused) and (not rule.others or any(holds(other) for other in rule.others)):
            raise click.UsageError(rule.message)
        if isinstance(rule, Needs) and not holds(rule.needed):
            raise click.UsageError(f"{label(rule.option)} needs {label(rule.needed)}: {rule.why}")
        if isinstance(rule, Excludes) and holds(rule.other):
            raise click.UsageError(f"{label(rule.option)} does not apply with {label(rule.other)}: {rule.why}")


SCENE_VEHICLE = Excludes("vehicle_name", "scene", "the scene's [vehicle] table decides the vehicle (set its preset "
                                                  "there)")


FLEET = "fleet mode (--out-dir, or several trajectories)"
ESCALATION = "escalation (--escalate, or --matcher auto without --no-escalate)"
SCHEDULED = "--out-dir or --window-seconds"
STDIN = "standard input (-) among the trajectories"
NO_OUT_DIR = "no --out-dir"
POSES_TO_STDOUT = "one replay's poses to standard output"
EVENTS_TO_STDOUT = "one replay's events to standard output"
SUMMARY_TO_STDOUT = "the summary to standard output"
POSES_NOT_A_FILE = "the poses not written to a file"
EVENTS_NOT_A_FILE = "the events not written to a file"
# checked first: what decides the replay's inputs and world
REPLAY_FIRST_RULES = (
    Refused("together", ("out_dir", "jobs", "scheduler"), "--together replays the files as one world into --poses "
                                                        "and --events: not with --out-dir, --jobs or --scheduler"),
    Refused("together", (STDIN,), "--together reads files, not standard input"),
    OneOf(("scene", "terrain"), "give --scene or --terrain (one of them)"),
    SCENE_VEHICLE,
)
REPLAY_RULES = (
    Needs("png_colour", "png", "it colours the path --png draws"),
    Needs("allow_off_terrain", "fail_on_collision", "it keeps rows off the terrain from failing the run"),
    *(Needs(name, ESCALATION, "it is the certificate's tolerance, which only escalation checks")
      for name in ("tolerance", "attitude_tolerance")),
    Needs("jobs", SCHEDULED, "it sets how many processes run a fleet's trajectories or an exercise's time windows"),
    Needs("split_lines", "out_dir", "it sets how a fleet runs, and a fleet writes one poses and one events file per "
                                    "trajectory there"),
    Needs("out_format", "out_dir", "it sets the format of the files a fleet writes there (one replay writes Parquet "
                                   "to --poses and --events ending in .parquet)"),
    Needs("scheduler", SCHEDULED, "it runs a fleet's trajectories or an exercise's time windows on the cluster"),
    Excludes("window_seconds", FLEET, "it cuts one exercise into time windows, written into --poses and --events"),
    Excludes("window_seconds", "together", "it reads one trajectory file (each window reads its own rows)"),
    Excludes("png", "window_seconds", "it draws a replay run in one piece"),
    Excludes("up", "scene", "the scene's [terrain] up key decides"),
    Excludes("poses_path", FLEET, "a fleet writes OUT/NAME.poses.csv for each trajectory (.parquet with "
                                  "--out-format parquet)"),
    Excludes("events_path", FLEET, "a fleet writes OUT/NAME.events.jsonl for each trajectory (.parquet with "
                                   "--out-format parquet)"),
    Excludes("cache", FLEET, "a fleet does not save its terrain beside it (classify it first with tankcd classify)"),
)
# checked after the values and the terrain: what the mode chosen cannot do
REPLAY_LAST_RULES = (
    Refused("fmt", (FLEET,), "--format names one input's format (or --together's inputs'): a fleet's files are each "
                             "told by their name and first bytes"),
    Refused("png", (FLEET,), "--png draws one replay; a fleet writes its files to --out-dir"),
    Refused(FLEET, (NO_OUT_DIR,), "several trajectories need --out-dir (one poses and one events file each)"),
    Refused(FLEET, (STDIN,), "a fleet reads files, not standard input"),
    Refused(POSES_TO_STDOUT, (EVENTS_TO_STDOUT, SUMMARY_TO_STDOUT),
            "poses already go to stdout: give --poses FILE to send events or the summary there"),
    Refused(EVENTS_TO_STDOUT, (SUMMARY_TO_STDOUT,), "events already go to stdout: give --summary FILE"),
    Refused("window_seconds", (STDIN,), "--window-seconds reads a trajectory file (each window reads its own rows), "
                                        "not standard input"),
    Refused("report_path", (FLEET,), "--report reviews one replay's --poses and --events; a fleet writes a pair per "
                                     "trajectory (run tankcd report on each)"),
    Refused("report_path", (POSES_NOT_A_FILE, EVENTS_NOT_A_FILE),
            "--report reads the replay's outputs back: give --poses FILE and --events FILE (not standard output)"),
)
REPLAY_VALUES = (
    Positive("window_seconds", "a window's length in seconds"),
    Positive("tolerance", "a height tolerance in metres"),
    Positive("attitude_tolerance", "an attitude tolerance in degrees"),
)


def check_replay_options(ctx: click.Context, mode: str) -> None:
    """replay's options that only make sense with (or without) another, in the replay ``mode``
    (``api.replay_mode``): a usage error each (a value out of range: bad input).

    --cache and --up also need a terrain classified on the fly: given a store (by --terrain or as
    the scene's terrain), they are refused too."""
    p = ctx.params
    fleet = mode == "fleet"
    one = not fleet
    summary = p.get("summary_path")
    conditions = {
        FLEET: fleet, SCHEDULED: given(ctx, "out_dir") or given(ctx, "window_seconds"),
        ESCALATION: bool(p.get("escalate") or (p.get("escalate") is None and p.get("matcher") == "auto")),
        STDIN: "-" in (p.get("trajectories") or ()), NO_OUT_DIR: p.get("out_dir") is None,
        POSES_TO_STDOUT: one and p.get("poses_path") == "-", EVENTS_TO_STDOUT: one and p.get("events_path") == "-",
        SUMMARY_TO_STDOUT: one and summary == "-",
        POSES_NOT_A_FILE: p.get("poses_path") in (None, "-"), EVENTS_NOT_A_FILE: p.get("events_path") in (None, "-"),
    }
    check_option_combinations(ctx, REPLAY_FIRST_RULES + REPLAY_RULES, conditions)
    check_option_values(ctx, REPLAY_VALUES)
    _check_store_options(ctx)
    check_option_combinations(ctx, REPLAY_LAST_RULES, conditions)


def _check_store_options(ctx: click.Context) -> None:
    """--cache and --up refused for a store's terrain."""
    p = ctx.params
    if not (given(ctx, "cache") or given(ctx, "up")):
        return
    from tankcd_cli.io.h5 import is_hdf5

    terrain, label = p.get("terrain"), "--terrain"
    if terrain is None and p.get("scene") and os.path.exists(p["scene"]):
        from tankcd_cli.scene import load_scene

        terrain, label = load_scene(p["scene"]).terrain_path, "the scene's terrain"
    if terrain is None or terrain == "-" or not os.path.isfile(terrain) or not is_hdf5(terrain):
        return
    for name, why in (("cache", "it saves a terrain classified on the fly as a store"),
                      ("up", "a store's terrain was turned z-up when it was classified")):
        if given(ctx, name):
            raise click.UsageError(f"{option_label(ctx, name)} does not apply to a store ({label} {terrain}): {why}")
