"""The streaming replay pipeline: trajectory chunks in, pose chunks and events out.

Per chunk (vectorized within it): match the poses, then only the effects the
scene calls for (``World.effects``; each effect's checks are its module's in
``replay.effects``): the hull bottom against the terrain always; the vehicle
against obstacles only if the scene has obstacles; the gun against the rear
drums only if drums are fitted and the trajectory moves the turret or gun; each
at the rows and, unless the replay is discrete, along the motion between them
(``replay.between_rows``); with many vehicles, their checks against each other.
Work a scene does not call for costs nothing: no tree is loaded, no column
computed.

Memory is bounded by the chunk (65 536 rows by default: a few tens of MB of
arrays) plus the terrain and trees, whatever the trajectory's length.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from tankcd_cli.gates import GateTally
from tankcd_cli.matching.match import OFF, Poses, match
from tankcd_cli.replay.between_rows import ROW_FIELDS, BetweenCounts, Rows, check_between
from tankcd_cli.replay.effects import BY_STAGE, OWN, Effects, seconds_keys
from tankcd_cli.replay.effects.vehicles import VehicleContacts
from tankcd_cli.replay.records import ReplayOptions
from tankcd_cli.replay.world import World


@dataclass
class ReplayRun:
    """One replay's state: the world and options it runs with, the effects of its trajectory, and
    what it has measured (seconds per stage, the checks between rows). A new one for every replay:
    nothing of one replay's state leaks into the next that shares the world.

    The world's surface, obstacles and default vehicle are reached as attributes of the run.
    ``turret_moves``: the trajectory gives turret or gun angles (the gun's checks run only then).
    ``vehicles``: the exercise's vehicle-against-vehicle checks (``VehicleContacts``), when the
    trajectory has entities."""

    world: World
    options: ReplayOptions
    turret_moves: bool
    seconds: dict = None  # seconds per stage (``replay.effects.seconds_keys``)
    between: BetweenCounts | None = None  # continuous only
    vehicles: VehicleContacts | None = None
    gates: GateTally = None  # what the gates skipped (``tankcd_cli.gates``); off with ``options.gates``

    def __post_init__(self):
        if self.gates is None:
            self.gates = GateTally(enabled=self.options.gates)
        if self.seconds is None:
            self.seconds = dict.fromkeys(seconds_keys(self.options.continuous, False), 0.0)
        if self.options.continuous and self.between is None:
            self.between = BetweenCounts()
        self._effects = {}
        self._kind_codes = np.zeros(0, dtype=np.int64)  # the kind of each entity code seen
        self.carry = None  # replay.between_rows.Rows: each entity's last row so far, by code

    surface = property(lambda self: self.world.surface)
    vehicle = property(lambda self: self.world.vehicle)
    obstacles = property(lambda self: self.world.obstacles)
    body = property(lambda self: self.world.body)
    matcher = property(lambda self: self.options.matcher)
    escalate = property(lambda self: self.options.escalate)
    tolerance = property(lambda self: self.options.tolerance)
    attitude_tolerance = property(lambda self: self.options.attitude_tolerance)
    continuous = property(lambda self: self.options.continuous)

    @property
    def effects(self) -> Effects:
        """The effects that ran, over the kinds of vehicle met (what the summary reports; the default
        vehicle's before any row)."""
        met = list(self._effects.values()) or [self.effects_of(self.world.kinds[0])]
        return Effects.any_of(met)

    def effects_of(self, kind) -> Effects:
        e = self._effects.get(kind.index)
        if e is None:
            e = self._effects[kind.index] = self.world.effects(self.turret_moves, kind.index)
        return e

    def kinds_of(self, codes: np.ndarray, names: tuple) -> np.ndarray:
        """(N,) the kind of vehicle of each row's entity code (``World.kind_of`` of its name)."""
        known = len(self._kind_codes)
        if len(names) > known:
            self._kind_codes = np.concatenate([self._kind_codes, np.array(
                [self.world.kind_of(name) for name in names[known:]], dtype=np.int64)])
        return self._kind_codes[codes] if len(self._kind_codes) else np.zeros(len(codes), dtype=np.int64)


def start_run(world: World, options: ReplayOptions, turret_moves: bool, entities: bool = False,
              source: str = "trajectory", ordered: bool = True) -> ReplayRun:
    """A replay's run of ``world`` for a trajectory whose turret or gun moves (or not), with many
    vehicles (``entities``: their checks against each other too) or one. ``ordered``: the rows are
    in time order across vehicles (``replay.effects.vehicles.OrderCheck``), so the vehicles' checks stream;
    else their segments are spilled to disk and checked at the end."""
    run = ReplayRun(world, options, turret_moves)
    if entities:
        run.seconds = dict.fromkeys(seconds_keys(options.continuous, True), 0.0)
        (between_vehicles,) = [e for e in BY_STAGE if not e.own]
        run.vehicles = between_vehicles.start(world, options.continuous, source, ordered, gates=run.gates)
    return run


def replay_chunks(run: ReplayRun, chunks, lead=None) -> Iterator[tuple[object, Poses, list]]:
    """Match every trajectory chunk and run the enabled effects at the rows and, unless the run is
    discrete, along the motion between them (``replay.between_rows``); yields (chunk, poses,
    events) in order, a chunk's events sorted by step and time. With many vehicles, their contacts
    with each other are events too, yielded with the chunk after which their time window closed.

    lead : the row just before the first chunk (a trajectory part's ``io.trajectory.lead_row``):
        placed and checked like the others but not yielded, so that the interval from it to the
        first row is checked here, under its step, exactly once over all the parts.
    """
    try:
        if lead is not None and len(lead):
            _chunk(run, lead)
        for chunk in chunks:
            poses, events = _chunk(run, chunk)
            if run.vehicles is not None:
                t0 = time.perf_counter()
                events += run.vehicles.ready(chunk)
                run.seconds["vehicles"] += time.perf_counter() - t0
            yield chunk, poses, events
        if run.vehicles is not None:
            t0 = time.perf_counter()
            tail = run.vehicles.finish()
            run.seconds["vehicles"] += time.perf_counter() - t0
            if tail:
                yield None, None, tail
    finally:
        close = getattr(run.vehicles, "close", None)  # the spill file, also when the replay fails
        if close is not None:
            close()


def _names(chunk) -> tuple:
    return chunk.entity_names if chunk.entity is not None and len(chunk.entity_names) else ("",)


def _codes(chunk) -> np.ndarray:
    return chunk.entity if chunk.entity is not None else np.zeros(len(chunk), dtype=np.int64)


def _take(chunk, idx):
    """The rows ``idx`` of a chunk, as a chunk (steps, lines and entities kept)."""

    arrays = {f: getattr(chunk, f)[idx] for f in ("step", "t", "x", "y", "yaw_deg", "turret_deg", "gun_deg")}
    for f in ("line", "entity", "piece_start"):
        value = getattr(chunk, f)
        arrays[f] = None if value is None else value[idx]
    return dataclasses.replace(chunk, **arrays)


def _chunk(run: ReplayRun, chunk):
    """One chunk: its poses and its events (sorted by step and time), the carry updated."""
    n = len(chunk)
    codes = _codes(chunk)
    kinds = run.kinds_of(codes, _names(chunk))
    present = np.unique(kinds)
    parts = []  # (kind, rows of the chunk, poses, row contacts)
    events = []
    for k in present:
        kind = run.world.kinds[int(k)]
        idx = np.arange(n) if len(present) == 1 else np.flatnonzero(kinds == k)
        part = chunk if len(present) == 1 else _take(chunk, idx)
        poses, found, contacts = _rows(run, kind, part)
        parts.append((kind, idx, part, poses, contacts))
        events += found
    poses = parts[0][3] if len(parts) == 1 else _scatter(n, [(p[1], p[3]) for p in parts])
    if run.continuous and n:
        t0 = time.perf_counter()
        for kind, idx, part, kposes, contacts in parts:
            rows = Rows(part.step, part.t, part.x, part.y, part.yaw_deg, part.turret_deg, part.gun_deg, kposes,
                        contacts, _codes(part),
                        part.piece_start if part.piece_start is not None else _first_rows(part))
            table = _with_carry(run, rows)
            result = check_between(table, kind, run, run.between, run.effects_of(kind).running(),
                                   want_segments=run.vehicles is not None)
            events += result.events
            _keep_last(run, table, result.swept_into)
            if run.vehicles is not None:
                run.vehicles.add(kind, result.segments)
        run.seconds["between"] += time.perf_counter() - t0
    elif run.vehicles is not None and n:
        for kind, idx, part, kposes, _ in parts:
            run.vehicles.add_rows(kind, part, kposes)
    if chunk.has_entity:
        names = _names(chunk)
        for e in events:
            e.extra["entity"] = names[e.entity]
    events.sort(key=lambda e: (e.step, e.t))
    return poses, events


def _first_rows(part) -> np.ndarray:
    """Without the reader's piece marks (rows given as arrays): every row continues the one before."""
    return np.zeros(len(part), dtype=bool)


def _rows(run: ReplayRun, kind, chunk):
    """The rows of one kind of vehicle: their poses, the events at them, and their contacts (each
    own effect's (N, ...) bool by its name: none where it does not run)."""
    t0 = time.perf_counter()
    poses = match(run.surface, kind.vehicle, chunk.x, chunk.y, np.radians(chunk.yaw_deg), matcher=run.matcher,
                  escalate=run.escalate, tolerance=run.tolerance, attitude_tolerance=run.attitude_tolerance,
                  gates=run.gates)
    run.seconds["matching"] += time.perf_counter() - t0
    events = []
    good = np.flatnonzero(poses.status != OFF)
    n = len(chunk)
    where = StepRows(chunk.step)
    effects = run.effects_of(kind)
    contacts = {}
    for effect, on in zip(OWN, effects.on):
        if on:
            t0 = time.perf_counter()
            found, contacts[effect.name] = effect.at_rows(run, kind, chunk, poses, good, where)
            events += found
            run.seconds[effect.name] += time.perf_counter() - t0
        else:
            contacts[effect.name] = effect.no_contacts(run, n)
    return poses, events, contacts


class StepRows:
    """Each step's row in a chunk (``where[step]``), what the effects mark their contacts at: built
    on the first look-up, so that a chunk without an event pays nothing (a dict of every step
    cost a Python loop over the rows)."""

    def __init__(self, steps: np.ndarray):
        self.steps = steps
        self._order = None

    def __getitem__(self, step: int) -> int:
        if self._order is None:
            self._order = np.argsort(self.steps, kind="stable")
            self._sorted = self.steps[self._order]
        k = int(np.searchsorted(self._sorted, step))
        if k >= len(self._sorted) or self._sorted[k] != step:
            raise KeyError(step)
        return int(self._order[k])


def _scatter(n: int, parts: list) -> Poses:
    """One chunk's poses from its kinds' poses at their rows."""
    out = {}
    for f in Poses.__dataclass_fields__:
        first = getattr(parts[0][1], f)
        arr = np.empty((n,) + first.shape[1:], dtype=first.dtype)
        for idx, p in parts:
            arr[idx] = getattr(p, f)
        out[f] = arr
    return Poses(**out)


def _with_carry(run: ReplayRun, rows):
    """The chunk's rows of one kind with each entity's carried last row before its first, sorted by
    entity (each entity's rows in their order): the table the checks between rows take."""
    carry = run.carry
    codes = np.unique(rows.entity)
    if carry is not None:
        have = codes[codes < len(carry.has)]
        have = have[carry.has[have]]
        table = Rows.join([carry.rows.take(have), rows]) if len(have) else rows
    else:
        table = rows
    # the carried rows come first for their entity: a stable sort by entity keeps the order
    if len(table) < 2 or (np.diff(table.entity) >= 0).all():
        return table
    return table.take(np.argsort(table.entity, kind="stable"))


class _Carry:
    """Each entity's last row so far (``rows``, indexed by entity code; ``has`` where one exists)."""

    def __init__(self, rows, has):
        self.rows = rows
        self.has = has


def _keep_last(run: ReplayRun, table, swept_into) -> None:
    """Each entity's last row in ``table`` becomes its carried row (its obstacle contacts including
    those of the stretch of motion that ended there)."""
    if len(table) == 0:
        return
    last = np.flatnonzero(np.append(table.entity[1:] != table.entity[:-1], True))
    codes = table.entity[last]
    rows = table.take(last)
    for name, into in swept_into.items():
        rows.contacts[name] = rows.contacts[name] | into[last]
    rows.carried = np.ones(len(last), dtype=bool)  # its piece mark stays: the first row of a piece still is
    size = int(codes.max()) + 1
    carry = run.carry
    if carry is None:
        idx = np.zeros(size, dtype=np.int64)
        base = rows.take(idx)
        has = np.zeros(size, dtype=bool)
    else:
        base, has = carry.rows, carry.has
        if size > len(has):
            grow = size - len(has)
            base = Rows.join([base, rows.take(np.zeros(grow, dtype=np.int64))])
            has = np.concatenate([has, np.zeros(grow, dtype=bool)])
    for f in ROW_FIELDS:
        getattr(base, f)[codes] = getattr(rows, f)
    for name, contact in rows.contacts.items():
        base.contacts[name][codes] = contact
    for f in Poses.__dataclass_fields__:
        getattr(base.poses, f)[codes] = getattr(rows.poses, f)
    has[codes] = True
    run.carry = _Carry(base, has)
