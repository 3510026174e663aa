"""One replay, from a trajectory to its written poses and events and its summary: ``run_replay``,
the entry point the command line, fleets (local and Dask), the demo and the Python API all call."""

from __future__ import annotations

import dataclasses
import os
import time
import warnings
from typing import Callable, Iterable

import numpy as np

from tankcd_cli.errors import InputError, collected_warnings, warn
from tankcd_cli.io.poses_csv import pose_columns
from tankcd_cli.io.trajectory import TrajectoryReader, lead_row, read_trajectory, utc_text
from tankcd_cli.names import NO_MATCHER, OFF, PLACED_BY
from tankcd_cli.replay.effects import resolution
from tankcd_cli.replay.outputs import check_writable, replay_metadata, replay_outputs
from tankcd_cli.replay.pipeline import ReplayRun, replay_chunks, start_run
from tankcd_cli.replay.plausibility import ExerciseChecks, MotionChecks
from tankcd_cli.replay.records import KINDS, ReplayCounts, ReplayOptions, ReplayOutputs, ReplaySummary, ReplayTally
from tankcd_cli.replay.effects.vehicles import OrderCheck
from tankcd_cli.replay.world import World


def run_replay(world: World, trajectory, outputs: ReplayOutputs = ReplayOutputs(),
               options: ReplayOptions = ReplayOptions(), part=None,
               progress: Callable[[int], None] | None = None,
               observe: Callable | None = None, sources: list | None = None) -> ReplaySummary:
    """Replay ``trajectory`` in ``world``: one pose row per trajectory row, in order, streamed in
    chunks, and the events of the effects the world calls for.

    trajectory : a path (any input ``io.trajectory.read_trajectory`` reads; geographic ones are
        converted to the terrain's CRS) or an iterable of ``io.trajectory.TrajectoryChunk``
    outputs : where the poses and events go (``ReplayOutputs``; a name ending in ``.parquet``:
        Parquet, else CSV and JSON Lines): written under temporary names and renamed into place
        together when complete (never one without the other)
    options : matcher, escalation, tolerance, continuous or discrete, chunk size
    part : a ``io.trajectory.TrajectoryPart`` of a CSV path: only its rows, their steps and lines
        those of the whole file; the row before it seeds the motion into its first row
    progress(rows) : after every chunk, the rows replayed so far
    observe(chunk, poses, events) : sees every chunk (a map of the replay)
    sources : the trajectory's files, for a Parquet output's metadata (default: ``trajectory``
        when it is a path; give them when it is chunks read from files, as an exercise's are)

    Steps no vehicle makes and headings that contradict the motion are set-up warnings
    (``replay.plausibility``); at the end, a trajectory mostly off the terrain is one too (the
    likeliest cause: other coordinates than the terrain's, local against UTM, or longitude and
    latitude given as x and y).
    """
    check_writable(outputs.poses, outputs.events)  # before the trajectory is read
    start = time.perf_counter()
    with collected_warnings() as said:
        summary = _run(world, trajectory, outputs, options, part, progress, observe, sources, start)
    summary.warnings = list(said)
    return summary


def _run(world, trajectory, outputs, options, part, progress, observe, sources, start) -> ReplaySummary:
    if isinstance(trajectory, str):
        source = trajectory
        chunks = read_trajectory(trajectory, chunk_rows=options.chunk_rows, part=part, crs=world.crs)
    else:
        source, chunks = "trajectory", iter(trajectory)
    first = next(chunks, None)
    entities = bool(first is not None and first.has_entity)
    ordered = in_time_order(trajectory, options, part, world.crs) if entities and options.continuous else True
    run = start_run(world, options, bool(first is not None and first.has_turret), entities=entities, source=source,
                    ordered=ordered)
    lead = lead_row(trajectory, part, crs=world.crs) if part is not None and isinstance(trajectory, str) else None
    counts = ReplayCounts()
    stream = _chain(first, chunks)
    if sources is None:
        sources = [trajectory] if isinstance(trajectory, str) else []

    origin = utc_text(first.time_origin) if first is not None else None  # the UTC instant of t = 0, or None

    def metadata():
        return replay_metadata(world, sources, options, hash_trajectories=part is None, time_origin=origin)

    with replay_outputs(outputs, entities, metadata) as (poses_out, events_out):
        write_replay(run, stream, poses_out, events_out, counts, source, lead=lead, progress=progress,
                     observe=observe)
    summary = summarize(counts, run, time.perf_counter() - start)
    summary.time_origin = origin
    return summary


def _chain(first, rest):
    if first is not None:
        yield first
    yield from rest


def write_replay(run: ReplayRun, chunks: Iterable, poses_out, events_out, counts: ReplayCounts,
                 source: str = "trajectory", lead=None, progress: Callable[[int], None] | None = None,
                 observe: Callable | None = None) -> ReplayCounts:
    """Replay the chunks, writing the poses to ``poses_out`` and the events to ``events_out``
    (``replay.outputs``' writers: CSV and JSON Lines, or Parquet; None: none, the events only
    counted); ``counts`` updated and returned."""
    checks = ExerciseChecks(source) if run.vehicles is not None else MotionChecks(source)
    for chunk, poses, events in replay_chunks(run, _checked(chunks, checks), lead=lead):
        if poses_out is not None and chunk is not None:
            poses_out.write(chunk, poses)
        if events_out is not None:
            events_out.write(events)
        counts.add(chunk, poses, events)
        if chunk is None:  # the vehicles' last contacts, after the last chunk
            if observe is not None:
                observe(None, None, events)
            continue
        if observe is not None:
            observe(chunk, poses, events)
        if progress is not None:
            progress(counts.rows)
    for out in (poses_out, events_out):
        if out is not None:
            out.finish()
    checks.finish()
    warn_if_beside(run.surface, counts, source, run.world.crs)
    return counts


def _checked(chunks, checks):
    """The chunks, each shown to the motion checks on its way to the replay."""
    for chunk in chunks:
        checks.where = chunk.where  # what the rows' numbers count in messages: lines, track points, packets
        if isinstance(checks, ExerciseChecks):
            checks.observe(chunk)
        else:
            checks.observe(chunk.t, chunk.x, chunk.y, chunk.yaw_deg, chunk.line)
        yield chunk


def warn_if_beside(surface, counts: ReplayCounts, source: str, crs: str = "") -> None:
    """A warning when most rows are off the terrain, naming both extents (and, for x, y that look
    like longitude and latitude over a projected terrain, the lon/lat columns)."""
    rows, off = counts.rows, counts.off_terrain_rows
    if rows == 0 or 2 * off <= rows:
        return
    lo, hi = surface.bounds()
    x0, y0, x1, y1 = (_coordinate(v) for v in counts.extent)
    hint = "are both in the same coordinates?"
    e = counts.extent
    if -180 <= e[0] <= e[2] <= 180 and -90 <= e[1] <= e[3] <= 90 and max(abs(lo[0]), abs(hi[1])) > 1000:
        hint = ("x and y look like longitude and latitude: name those columns lon and lat, and the trajectory is "
                "converted to the terrain's CRS" + ("" if crs else " (this terrain has none: classify it with --crs)"))
    warn(source, f"{off:,} of {rows:,} rows are off the terrain: the trajectory spans x {x0} to {x1}, "
                 f"y {y0} to {y1}; the terrain x {lo[0]:.1f} to {hi[0]:.1f}, y {lo[1]:.1f} to {hi[1]:.1f} ({hint})")


def _coordinate(v: float) -> str:
    """A coordinate for a message: to a decimetre, or in powers of ten when it is no map coordinate."""
    return f"{v:.1f}" if abs(v) < 1e12 else f"{v:.3g}"


def summarize(counts: ReplayCounts, run: ReplayRun, seconds: float) -> ReplaySummary:
    """The closing summary of a replay's counts."""
    motion = {}
    if run.continuous:
        from tankcd_cli.replay.effects import resolution

        motion = {"intervals": run.between.intervals, "substeps": run.between.substeps, **resolution(run.surface)}
    tally = ReplayTally(counts, run.effects.as_dict(), dict(run.seconds), motion, run.gates.as_dict())
    return summary_of(tally, run.continuous, seconds,
                      int(run.carry.has.sum()) if run.carry is not None else (1 if counts.rows else 0))


def summary_of(tally: ReplayTally, continuous: bool, seconds: float, entities: int) -> ReplaySummary:
    """The closing summary of a replay's tally (``records.ReplayTally``: its counts, effects, each
    stage's seconds, the checks between rows), the one way every summary is built: a run in one
    piece's (``summarize``), a replay by time windows' over its windows' tallies merged, a split
    trajectory's over its parts' (``joined_summary``). ``seconds`` the replay's time, ``entities``
    its vehicles."""
    counts = tally.counts
    return ReplaySummary(rows=counts.rows, collisions={k: counts.at_rows[k] for k in KINDS},
                         off_terrain=counts.at_rows["off_terrain"], effects=dict(tally.effects),
                         matchers={**{name: int(c) for name, c in zip(PLACED_BY, counts.matcher) if c},
                                   **({NO_MATCHER: int(counts.status[OFF])} if counts.status[OFF] else {})},
                         seconds=round(seconds, 3),
                         seconds_by_effect={k: round(v, 3) for k, v in tally.seconds_by_effect.items()},
                         mode="continuous" if continuous else "discrete",
                         between=dict(counts.between) if continuous else {},
                         motion=dict(tally.motion) if continuous else {},
                         vehicle_contacts=counts.vehicle_contacts, entities=entities, gates=dict(tally.gates))


def joined_summary(summaries: list) -> ReplaySummary:
    """One summary of a trajectory's pieces (``ReplaySummary`` each, in order), built from their
    tallies merged as a run in one piece builds its own: seconds summed, the warnings of all (each
    once), the rest (mode, entities, time origin) as the first piece's."""
    first = summaries[0]
    tally = ReplayTally()
    for s in summaries:
        tally.merge(ReplayTally.of_summary(s))
    built = summary_of(tally, first.mode == "continuous", sum(s.seconds for s in summaries), first.entities)
    return dataclasses.replace(built, warnings=list(dict.fromkeys(w for s in summaries for w in s.warnings)),
                               time_origin=first.time_origin)


def replay_rows(world: World, trajectory, options: ReplayOptions = ReplayOptions()) -> tuple[dict, list]:
    """``run_replay`` kept in memory: (poses, events) with poses a dict of arrays keyed by the poses
    CSV's columns (names for region, matcher and status; NaN where a row has no pose) and events
    a list of dicts as the events file's lines. For a trajectory that fits in memory (the Python
    API); a long one streams to files with ``run_replay``."""
    parts = []
    events = []

    def keep(chunk, poses, evs):
        if chunk is not None:
            parts.append(pose_columns(chunk.step, chunk.t, poses, chunk.names() if chunk.has_entity else None))
        events.extend(e.as_dict() for e in evs)

    run_replay(world, trajectory, ReplayOutputs(poses=None, events=None), options, observe=keep)
    if not parts:
        return pose_columns(np.zeros(0, np.int64), np.zeros(0), None), events
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}, events


def in_time_order(trajectory, options: ReplayOptions, part=None, crs: str | None = None) -> bool:
    """Whether an exercise's rows are in time order across vehicles, as the streaming checks between
    vehicles need them (``replay.effects.vehicles.OrderCheck``): one pass over a regular file (or any
    iterable of chunks that can be read again: ``iter`` gives a new iterator), stopping at the first
    row out of order. Standard input, a pipe or a one-pass iterator cannot be read twice: False
    (their segments are spilled, correct whatever the order). A bad row or warning here is left to
    the replay's own pass, which says it where it is."""
    import os
    import warnings

    from tankcd_cli.errors import InputError
    from tankcd_cli.replay.effects.vehicles import OrderCheck

    if isinstance(trajectory, str):
        if not os.path.isfile(trajectory):
            return False
        # times and entities only: a geographic input's coordinates need no conversion here
        chunks = TrajectoryReader(trajectory, options.chunk_rows, part, crs, convert=False)
    else:
        chunks = iter(trajectory)
        if chunks is trajectory:
            return False
    check = OrderCheck()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for chunk in chunks:
                if not check.observe(chunk):
                    break
    except InputError:
        return False
    finally:
        close = getattr(chunks, "close", None)
        if close is not None:
            close()
    return check.ordered
