"""tankcd replay TRAJECTORY: poses along a trajectory, and the collision events the scene calls for."""

from __future__ import annotations

import contextlib
import json

import click

from tankcd_cli import api
from tankcd_cli.cli.options import (REPLAY_VEHICLE_HELP, check_replay_options, no_dash_directory, no_stdin,
                                    refuse_clashes, vehicle_option, verbosity_options)
from tankcd_cli.errors import InputError, collected_warnings
from tankcd_cli.io.atomic import atomic_path, check_folders, committed_together, output_text
from tankcd_cli.io.input_formats import FORMAT_NAMES, with_format
from tankcd_cli.replay.drawing import ReplayDrawing
from tankcd_cli.replay.fleet import expand_trajectories
from tankcd_cli.replay.outputs import OUTPUT_FORMATS, check_writable
from tankcd_cli.replay.world import WorldSpec, world_inputs
from tankcd_cli.names import EXIT_BAD_INPUT, EXIT_COLLISION, EXIT_INTERNAL, MATCHER_CHOICES, UP_AXES

SUMMARY_STDERR = "<stderr>"  # --summary given without a file


@click.command(short_help="Replay a trajectory: poses to stdout or --poses, events to --events.")
@click.argument("trajectories", nargs=-1, required=True)
@click.option("--scene", type=click.Path(), default=None, callback=no_stdin,
              help="Scene TOML: terrain, vehicle, obstacles; it decides which effects run.")
@click.option("--terrain", "terrain", type=click.Path(), default=None,
              help="Terrain store, or any terrain input (classified on the fly), instead of a scene.")
@click.option("--poses", "poses_path", type=click.Path(dir_okay=False, allow_dash=True), default="-",
              show_default=True, help="Poses CSV output (- for stdout); a name ending in .parquet writes Parquet "
                                      "(pip install 'tankcd[parquet]').")
@click.option("--events", "events_path", type=click.Path(dir_okay=False, allow_dash=True), default=None,
              help="Events JSON Lines output (collisions, terrain contact, off-terrain); a name ending in .parquet "
                   "writes Parquet.")
@click.option("--matcher", type=click.Choice(MATCHER_CHOICES),
              default="auto", show_default=True, help="Terrain matcher (auto: by the region class under the footprint).")
@click.option("--escalate/--no-escalate", default=None,
              help="Check every key-point pose against the reference's certificate and solve those that fail "
                   "it by the reference: every pose within --tolerance of the reference (default: on for "
                   "--matcher auto, off for a matcher named; about 1.5x plain auto's whole replay, 2x its "
                   "matching).")
@click.option("--tolerance", type=click.FloatRange(min=0.0, min_open=True), default=None, metavar="M",
              help="With escalation: the certificate's height tolerance at the footprint's corners, m (default: "
                   "half the footprint's shorter side times tan 1 degree; 0.029 m for a T-72).")
@click.option("--attitude-tolerance", "attitude_tolerance", type=click.FloatRange(min=0.0, min_open=True),
              default=None, metavar="DEG",
              help="With escalation: the certificate's attitude tolerance, degrees: a key-point pose tilted more "
                   "than this from a plane the certificate finds is escalated (default: 0.5).")
@click.option("--format", "fmt", type=click.Choice(FORMAT_NAMES, case_sensitive=False), default=None,
              help="The trajectory's format where neither its name nor its first bytes say (standard input, any "
                   "suffix): csv, gpx, pcap or pcapng; gzip-compressed inputs are read as they are.")
@click.option("--together", is_flag=True,
              help="Several trajectories as one exercise: their rows merged in time into one world (each file an "
                   "entity named after its stem, or its own entities), one poses and one events output, every "
                   "contact between the vehicles found. Files with absolute times (GPX, captures, ISO 8601 times) "
                   "meet at their UTC times, t counting from the earliest.")
@click.option("--no-gates", "no_gates", is_flag=True,
              help="Run the exact checks everywhere, also where the conservative gates prove they can find "
                   "nothing (the same poses and events, byte for byte; slower): for tests and comparison.")
@click.option("--discrete", is_flag=True,
              help="Check the effects at the rows only (the paper's frame-by-frame way, for comparison); by "
                   "default they are checked along the motion between rows too.")
@vehicle_option(help_text=REPLAY_VEHICLE_HELP)
@click.option("--up", type=click.Choice(UP_AXES), default=None,
              help="Up axis of a terrain mesh classified on the fly (default: the format's convention, y for "
                   "glTF and GLB, z for the rest).")
@click.option("--cache", is_flag=True, help="Save a terrain classified on the fly as a store beside it, and reuse it "
                                            "(one replay; not with a store).")
@click.option("--fail-on-collision", is_flag=True,
              help="Exit 1 when any collision (obstacle, internal, terrain) occurs or a row is off the terrain.")
@click.option("--allow-off-terrain", is_flag=True, help="With --fail-on-collision: rows off the terrain do not fail.")
@click.option("--summary", "summary_path", is_flag=False, flag_value=SUMMARY_STDERR, default=None, metavar="[FILE]",
              help="The closing summary as JSON: one line on stderr (under -q too), or into FILE (- for stdout).")
@click.option("--png", type=click.Path(dir_okay=False), default=None,
              help="Draw the path over the class map, obstacles' footprints and the events, to this PNG.")
@click.option("--png-colour", "png_colour", type=click.Choice(["path", "matcher"]), default="path",
              show_default=True,
              help="With --png: colour the drawn path plainly or by the matcher that placed each pose.")
@click.option("--report", "report_path", type=click.Path(dir_okay=False), default=None, metavar="OUT",
              help="Then review the replay's --poses and --events files into OUT, as tankcd report -o OUT does "
                   "(.html, .geojson, .czml, or .pcap when the trajectory is a DIS capture).")
@click.option("--out-dir", type=click.Path(file_okay=False), default=None, callback=no_dash_directory,
              help="Fleet mode: one poses and one events file per trajectory here, and fleet.json.")
@click.option("--out-format", type=click.Choice(list(OUTPUT_FORMATS)), default="csv", show_default=True,
              help="Fleet mode: the per-trajectory files as NAME.poses.csv and NAME.events.jsonl, or as "
                   "NAME.poses.parquet and NAME.events.parquet (pip install 'tankcd[parquet]').")
@click.option("--jobs", type=click.IntRange(1, 512), default=None,
              help="Fleet mode: parallel processes (default: the number of cores); with --window-seconds: the "
                   "processes running the windows (default: 1, here).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Fleet mode on a Dask cluster (tcp://host:8786; pip install 'tankcd[dask]').")
@click.option("--window-seconds", type=float, default=None, metavar="S",
              help="Replay one exercise by time windows of about S seconds (a whole number of the 2 s contact "
                   "windows), each a task: here one after the other, in --jobs processes, or on the Dask cluster at --scheduler; the "
                   "poses and events of a run in one piece, byte for byte.")
@click.option("--split-lines", type=click.IntRange(1000, None), default=1_000_000, show_default=True,
              help="Fleet mode: replay a longer trajectory as parts of this many lines on several workers.")
@verbosity_options
@click.pass_obj
def replay(report, trajectories, scene, terrain, poses_path, events_path, matcher, escalate, tolerance,
           attitude_tolerance, fmt, together,
           no_gates, discrete, vehicle_name, up, cache,
           fail_on_collision, allow_off_terrain, summary_path, png, png_colour, report_path, out_dir, out_format, jobs,
           scheduler, split_lines, window_seconds):
    """Replay TRAJECTORY (CSV with t, x, y, yaw_deg, optional turret_deg, gun_deg; - for stdin):
    one pose row per trajectory row, in order, streamed in chunks, and the events of the
    effects the scene calls for (no obstacles, no obstacle checks; no drums or no turret
    motion, no gun checks; the hull bottom against the terrain always).

    Poses and events to a name ending in .parquet are written as Parquet (typed columns; the CRS,
    conventions and the sources' SHA-256 in the file's metadata).

    Fleets: several trajectories, globs ('runs/*.csv') or list files (@runs.txt) with --out-dir
    replay each into OUT/NAME.poses.csv and OUT/NAME.events.jsonl (--out-format parquet:
    NAME.poses.parquet and NAME.events.parquet), in parallel (--jobs) or on a Dask cluster
    (--scheduler), and write OUT/fleet.json. A failing trajectory does not stop the
    others; the exit code is 3 (bad input) or 4 (internal error) if any failed.

    Headings: yaw_deg is measured from east (+x), counter-clockwise (90 = north), as in the
    poses; a compass bearing (from north, clockwise) is 90 - bearing."""
    ctx = click.get_current_context()
    mode = api.replay_mode(trajectories, out_dir, window_seconds, together, jobs, scheduler)
    check_replay_options(ctx, mode)
    if fmt is not None:
        trajectories = tuple(with_format(t, fmt) for t in trajectories)
    how = dict(matcher=matcher, escalate=escalate, tolerance=tolerance, discrete=discrete,
               attitude_tolerance=attitude_tolerance, gates=not no_gates)
    if mode == "fleet":
        return _fleet(report, trajectories, scene, terrain, how, vehicle_name, up, out_dir, out_format, jobs, scheduler,
                      fail_on_collision, allow_off_terrain, summary_path, split_lines)
    trajectory = expand_trajectories(list(trajectories)) if mode == "together" else trajectories[0]
    summary_file = None if summary_path in (None, SUMMARY_STDERR, "-") else summary_path
    check_writable(poses_path, events_path)  # before the world is loaded
    check_folders(poses_path, events_path, png, summary_file)  # every output's folder, before any work
    report.kernels()
    step = report.progress("replay")
    spec = WorldSpec(scene=scene, terrain=terrain, vehicle=vehicle_name, up=up, cache=cache)
    refuse_clashes({**({f"TRAJECTORY {p}": p for p in trajectory} if together else {"TRAJECTORY": trajectory}),
                    **world_inputs(spec)},
                   {"--poses": poses_path, "--events": events_path, "--png": png, "--summary": summary_file,
                    "--report": report_path})
    review_kind, capture = None, None
    if report_path is not None:  # the review's own checks (its clashes: above), before any work too
        capture = _replayed_capture(trajectory, fmt) if not together else None
        if report_path.lower().endswith(".pcap") and capture is None:
            raise InputError(report_path, "a .pcap review copies the DIS capture replayed, with Collision PDUs "
                                          "among its packets: the trajectory is no capture (or several files "
                                          "--together: run tankcd report --capture on one)")
        review_kind = api.check_report(poses_path, events_path, report_path,
                                       capture if report_path.lower().endswith(".pcap") else None)
    world, loading = None, []
    if not (mode == "windows" and scheduler):  # on a cluster the workers load it
        # one piece's summary lists the world's warnings too
        with collected_warnings() if mode != "windows" else contextlib.nullcontext([]) as loading:
            world = api.load_world(scene=scene, terrain=terrain, vehicle=vehicle_name, up=up, cache=cache,
                                   progress=step)
    if review_kind is not None and world is not None:
        api.require_report_crs(review_kind, world, scene or terrain)
    drawing = ReplayDrawing(colour_by=png_colour) if png else None
    with committed_together():  # poses, events, picture and summary: all of them or none
        result = api.run_replay(trajectory, poses_path, events_path, window_seconds=window_seconds, together=together,
                                jobs=jobs, scheduler=scheduler, world=world, scene=scene, terrain=terrain,
                                vehicle=vehicle_name, up=up, progress=lambda n: report.bar(f"replay: {n:,} rows"),
                                observe=drawing.observe if drawing else None, **how)
        report.bar(None)
        result.warnings = list(loading) + result.warnings
        result.seconds = round(report.elapsed(), 3)  # the whole command's, as the summary has always said
        if drawing is not None:
            step(f"drawing {png}")
            # the map draws a mesh's classes only when classified here (a mesh store read from disk: none)
            opened = world.terrain
            mesh_store = opened.mesh_store if opened.classified else None
            with atomic_path(png, ".png") as tmp:
                drawing.save(tmp, mesh_store if mesh_store is not None else _store_of(world.surface), world.obstacles)
        _write_summary(summary_path, result.as_dict())
    _report_summary(report, result.as_dict(), summary_path, result.effects, result.rows, written=True)
    if report_path is not None:  # the replay's files are whole now: read them back
        got = api.report(poses_path, events_path, report_path, scene=scene, terrain=terrain,
                         capture=capture if review_kind == ".pcap" else None, world=world, vehicle=vehicle_name, up=up,
                         progress=report.progress("report"))
        from tankcd_cli.cli.review_command import closing_line

        report.info(closing_line(got))
    _exit_on_failures(result, fail_on_collision, allow_off_terrain)


def _replayed_capture(trajectory, fmt) -> str | None:
    """The trajectory when it is a DIS capture (by --format, its name or its first bytes), else None."""
    from tankcd_cli.io.trajectory.formats import trajectory_format

    if not isinstance(trajectory, str) or trajectory == "-":
        return None
    try:
        kind = trajectory_format(trajectory, fmt)
    except (OSError, ValueError):  # unreadable: the replay itself names what is wrong
        return None
    return str(trajectory) if kind in ("pcap", "pcapng") else None


def _store_of(surface):
    """What the map draws the classes from: a grid store's path, or a mesh store read again."""
    path = getattr(getattr(surface, "tiles", None), "path", None)
    if path is not None:
        return path
    return getattr(surface, "store", None)


def _write_summary(summary_path, result: dict) -> None:
    """--summary FILE or - (stdout): the summary as JSON."""
    if summary_path in (None, SUMMARY_STDERR):
        return
    with output_text(summary_path, ".json") as fh:
        fh.write(json.dumps(result, indent=None if summary_path == "-" else 2) + "\n")


def _report_summary(report, result: dict, summary_path, effects: dict, rows: int, written: bool = False) -> None:
    if not written:  # (``written``: the command wrote the summary with its other outputs)
        _write_summary(summary_path, result)
    if summary_path == SUMMARY_STDERR:
        click.echo(json.dumps(result), err=True)
    else:
        kinds = ", ".join(f"{k} {v}" for k, v in result["collisions"].items())
        ran = ", ".join(k for k, v in effects.items() if v)
        between = ""
        if result.get("mode") == "continuous":
            found = ", ".join(f"{k} {v}" for k, v in result["between"].items() if v) or "none"
            between = (f"; between rows ({result['motion']['substep_travel_m']:g} m / "
                       f"{result['motion']['substep_turn_deg']:g} deg sub-steps, obstacles exact): {found}")
        vehicles = ""
        if result.get("entities", 1) > 1:
            n = result["vehicle_contacts"]
            vehicles = f"; {result['entities']:,} vehicles, {n:,} contact{'' if n == 1 else 's'} between them"
        report.info(f"replay: {rows:,} rows; collisions at rows: {kinds}; off terrain {result['off_terrain']}"
                    f"{between}{vehicles}; effects: {ran} ({report.elapsed():.2f} s)")


def _exit_on_failures(result, fail_on_collision: bool, allow_off_terrain: bool) -> None:
    """--fail-on-collision: exit 1 on a collision (at a row or between rows), or on rows off the
    terrain unless allowed (a ``ReplaySummary`` or a ``FleetSummary``)."""
    if not fail_on_collision:
        return
    off = result.off_terrain + result.between.get("off_terrain", 0)
    if result.collided or (off and not allow_off_terrain):
        click.get_current_context().exit(EXIT_COLLISION)


def _fleet(report, trajectories, scene, terrain, how, vehicle_name, up, out_dir, out_format, jobs, scheduler,
           fail_on_collision, allow_off_terrain, summary_path, split_lines):
    report.kernels()
    step = report.progress("replay")
    finished = []

    def on_result(r):
        finished.append(r)
        report.bar(f"replay: {len(finished)} tasks done")

    fleet = api.run_replay(list(trajectories), out_dir=out_dir, scene=scene, terrain=terrain, vehicle=vehicle_name,
                           up=up, jobs=jobs, scheduler=scheduler, split_lines=split_lines, say=step,
                           on_result=on_result, out_format=out_format, **how)
    report.bar(None)
    for failure in fleet.failures:
        click.echo(f"tankcd: error: {failure['error']}", err=True)
    if report.verbosity >= 1:  # -v: the tracebacks of the internal errors, as the workers formatted them
        for r in fleet.results:
            if r.traceback:
                click.echo(f"{r.trajectory}: the traceback in its worker (pid {r.pid}):\n{r.traceback.rstrip()}",
                           err=True)
    brief = fleet.as_dict(results=False)
    _write_summary(summary_path, brief)
    if summary_path == SUMMARY_STDERR:
        click.echo(json.dumps(brief), err=True)
    else:
        kinds = ", ".join(f"{k} {v}" for k, v in fleet.collisions.items())
        found = ", ".join(f"{k} {v}" for k, v in fleet.between.items() if v) or "none"
        report.info(f"replay: {fleet.ok}/{fleet.trajectories} trajectories, {fleet.rows:,} rows on "
                    f"{fleet.ran_on}; collisions at rows: {kinds}; between rows: {found}; {fleet.failed} failed; "
                    f"wrote {out_dir}/fleet.json ({report.elapsed():.2f} s)")
    statuses = {f["status"] for f in fleet.failures}
    ctx = click.get_current_context()
    if "internal_error" in statuses:
        ctx.exit(EXIT_INTERNAL)
    if "bad_input" in statuses:
        ctx.exit(EXIT_BAD_INPUT)
    _exit_on_failures(fleet, fail_on_collision, allow_off_terrain)
