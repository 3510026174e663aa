"""One replay from chunks to written poses and events, and its summary (shared by `replay` and fleets)."""

from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass, field
from typing import Callable, Iterable

import numpy as np

from tankcd_cli.replay.pipeline import ReplaySetup

KINDS = ("obstacle", "internal", "terrain")


def new_counts() -> dict:
    from tankcd_cli.matching.match import PLACED_BY, STATUS

    return {"rows": 0, "status": np.zeros(len(STATUS), int), "matcher": np.zeros(len(PLACED_BY), int),
            "events": {"obstacle": 0, "internal": 0, "terrain": 0, "off_terrain": 0},
            "between": {"obstacle": 0, "internal": 0, "terrain": 0, "off_terrain": 0},
            "extent": [np.inf, np.inf, -np.inf, -np.inf]}  # the trajectory's x min, y min, x max, y max


def write_replay(setup: ReplaySetup, chunks: Iterable, matcher: str, out, ev_out, counts: dict,
                 on_chunk: Callable[[int], None] | None = None, source: str | None = None,
                 observe: Callable | None = None) -> dict:
    """Replay the chunks, writing the poses CSV to ``out`` (flushed per chunk) and the events to
    ``ev_out`` (or only counting them when None); returns ``counts`` updated.

    ``observe(chunk, poses, events)`` sees every chunk (a map of the replay). Steps no vehicle
    makes and headings that contradict the motion are warnings (``replay.plausibility``); at the
    end, a trajectory (``source``) mostly off the terrain is one too: the likeliest cause is a
    trajectory in other coordinates than the terrain's (local against UTM).
    """
    from tankcd_cli.io.events import event_line
    from tankcd_cli.io.poses_csv import format_rows, header
    from tankcd_cli.matching.match import PLACED_BY, STATUS
    from tankcd_cli.replay.pipeline import replay_chunks
    from tankcd_cli.replay.plausibility import MotionChecks

    checks = MotionChecks(source or "trajectory")
    out.write(header())
    for chunk, poses, events in replay_chunks(setup, _checked(chunks, checks), matcher):
        out.write(format_rows(chunk.step, chunk.t, poses, PLACED_BY, STATUS))
        out.flush()
        for e in events:
            counts["between" if e.extra.get("between") else "events"][e.kind] += 1
            if ev_out is not None:
                ev_out.write(event_line(e.step, e.t, e.kind, e.a, e.b, **e.extra))
        counts["rows"] += len(chunk)
        counts["status"] += np.bincount(poses.status, minlength=len(STATUS))
        counts["matcher"] += np.bincount(poses.matcher, minlength=len(PLACED_BY))
        _grow_extent(counts["extent"], chunk.x, chunk.y)
        if observe is not None:
            observe(chunk, poses, events)
        if on_chunk is not None:
            on_chunk(counts["rows"])
    checks.finish()
    _warn_if_beside(setup.surface, counts, source)
    return counts


def _checked(chunks, checks):
    """The chunks, each shown to the motion checks on its way to the replay."""
    for chunk in chunks:
        checks.observe(chunk.t, chunk.x, chunk.y, chunk.yaw_deg, chunk.line)
        yield chunk


def _grow_extent(extent: list, x: np.ndarray, y: np.ndarray) -> None:
    if len(x):
        with np.errstate(invalid="ignore"):
            extent[0] = min(extent[0], float(np.fmin.reduce(x)))
            extent[1] = min(extent[1], float(np.fmin.reduce(y)))
            extent[2] = max(extent[2], float(np.fmax.reduce(x)))
            extent[3] = max(extent[3], float(np.fmax.reduce(y)))


def off_terrain_rows(counts: dict) -> int:
    """Rows whose pose is not wholly on the terrain (status off or partly off)."""
    from tankcd_cli.matching.match import OK

    return int(counts["rows"] - counts["status"][OK])


def _warn_if_beside(surface, counts: dict, source: str | None) -> None:
    from tankcd_cli.errors import warn

    rows, off = counts["rows"], off_terrain_rows(counts)
    if rows == 0 or 2 * off <= rows:
        return
    lo, hi = surface.bounds()
    x0, y0, x1, y1 = (_coordinate(v) for v in counts["extent"])
    warn(source or "trajectory",
         f"{off:,} of {rows:,} rows are off the terrain: the trajectory spans x {x0} to {x1}, "
         f"y {y0} to {y1}; the terrain x {lo[0]:.1f} to {hi[0]:.1f}, y {lo[1]:.1f} to {hi[1]:.1f} "
         "(are both in the same coordinates?)")


def _coordinate(v: float) -> str:
    """A coordinate for a message: to a decimetre, or in powers of ten when it is no map coordinate."""
    return f"{v:.1f}" if abs(v) < 1e12 else f"{v:.3g}"


@dataclass
class ReplaySummary:
    """A replay's closing summary (docs/formats.md, "Replay summary").

    rows : trajectory rows read (each gave a pose row)
    collisions : events at the rows per kind (obstacle, internal, terrain)
    off_terrain : rows whose footprint is not wholly on the terrain
    effects : which effects ran; matchers : rows per matcher (what placed them)
    seconds : the replay's time; seconds_by_effect : matching and each effect's share of it
    mode : "continuous" (every effect along the motion between rows too) or "discrete" (rows only)
    between : contacts that began between rows, per kind (obstacle, internal, terrain, off_terrain)
    motion : what the checks between rows did and their resolution (intervals, sub-steps placed,
        the sub-steps' largest travel and turn, obstacles' leaf bound, the gun's step)
    """

    rows: int
    collisions: dict
    off_terrain: int
    effects: dict
    matchers: dict
    seconds: float
    seconds_by_effect: dict
    mode: str = "continuous"
    between: dict = field(default_factory=dict)
    motion: dict = field(default_factory=dict)

    @property
    def collided(self) -> bool:
        """Whether any collision was found, at a row or between rows."""
        return bool(sum(self.collisions.values()) or sum(v for k, v in self.between.items() if k != "off_terrain"))

    def as_dict(self) -> dict:
        return asdict(self)


def summary(counts: dict, setup: ReplaySetup, seconds: float) -> ReplaySummary:
    """The closing summary of ``write_replay``'s counts."""
    from tankcd_cli.matching.match import PLACED_BY

    motion = {}
    if setup.continuous:
        from tankcd_cli.replay.between_rows import resolution

        between = setup.between
        motion = {"intervals": between.intervals if between else 0, "substeps": between.substeps if between else 0,
                  **resolution(setup.surface)}
    return ReplaySummary(rows=counts["rows"], collisions={k: counts["events"][k] for k in KINDS},
                         off_terrain=counts["events"]["off_terrain"], effects=dict(setup.effects),
                         matchers={name: int(c) for name, c in zip(PLACED_BY, counts["matcher"]) if c},
                         seconds=round(seconds, 3),
                         seconds_by_effect={k: round(v, 3) for k, v in setup.seconds.items()},
                         mode="continuous" if setup.continuous else "discrete",
                         between=dict(counts["between"]) if setup.continuous else {}, motion=motion)


def write_outputs(setup: ReplaySetup, chunks: Iterable, matcher: str, poses_path: str, events_path: str | None,
                  counts: dict, source: str | None = None, on_chunk: Callable[[int], None] | None = None,
                  observe: Callable | None = None) -> dict:
    """``write_replay`` into the poses output (``-`` for stdout) and the events output (None: only
    counted), each written atomically (``io.atomic.output_text``) and both renamed in place together
    (``committed_together``: never one without the other); returns ``counts`` updated."""
    from tankcd_cli.io.atomic import committed_together, output_text

    with committed_together(), output_text(poses_path, ".csv", newline="") as out, \
            output_text(events_path, ".jsonl") as ev:
        write_replay(setup, chunks, matcher, out, ev, counts, on_chunk=on_chunk, source=source, observe=observe)
    return counts


def replay_to_files(surface, vehicle, scene, trajectory: str, poses_path: str, events_path: str | None,
                    matcher: str = "auto", setup_cache: dict | None = None, part=None) -> dict:
    """Replay one trajectory file (or one :class:`~tankcd_cli.io.trajectory.TrajectoryPart` of it)
    into a poses file and an events file, both written atomically.

    ``setup_cache`` keeps the loaded effects (obstacle trees) between calls with the same scene.
    The summary also gives the first row's line and the first and last times, which is what
    joining parts needs to check that time never goes back across them.
    """
    import time

    from tankcd_cli.io.trajectory import read_trajectory
    from tankcd_cli.replay.pipeline import prepare

    start = time.perf_counter()
    chunks = read_trajectory(trajectory, part=part)
    first = next(chunks, None)
    turret_moves = bool(first is not None and first.has_turret)
    key = turret_moves
    if setup_cache is not None and key in setup_cache:
        setup = setup_cache[key]
        setup.seconds = {k: 0.0 for k in setup.seconds}
    else:
        setup = prepare(surface, vehicle, scene, turret_moves)
        if setup_cache is not None:
            setup_cache[key] = setup
    counts = new_counts()
    ends = {"first_line": first.first_line if first else None, "t_first": float(first.t[0]) if first else None,
            "t_last": None}

    def remember_last(chunks):
        for chunk in chunks:
            ends["t_last"] = float(chunk.t[-1])
            yield chunk
    stream = remember_last(itertools.chain([first] if first else [], chunks))
    write_outputs(setup, stream, matcher, poses_path, events_path, counts, source=trajectory)
    return {**summary(counts, setup, time.perf_counter() - start).as_dict(), **ends}
