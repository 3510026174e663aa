"""The streaming replay pipeline: trajectory chunks in, pose chunks and events out.

Per chunk (vectorized within it): match the poses, then only the effects the
scene calls for (``World.effects``): the hull bottom against the terrain
always; the vehicle against obstacles only if the scene has obstacles (broad
phase on world boxes first); the gun against the rear drums only if drums are
fitted and the trajectory moves the turret or gun; each at the rows and, unless
the replay is discrete, along the motion between them (``replay.between_rows``).
Work a scene does not call for costs nothing: no tree is loaded, no column
computed.

Memory is bounded by the chunk (65 536 rows by default: a few tens of MB of
arrays) plus the terrain and trees, whatever the trajectory's length.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

from tankcd_cli.matching.match import OFF, OK, Poses, match
from tankcd_cli.replay.records import Event, ReplayOptions
from tankcd_cli.replay.world import Effects, World
from tankcd_cli.tolerances import HULL_CONTACT as HULL_CONTACT_TOLERANCE


@dataclass
class ReplayRun:
    """One replay's state: the world and options it runs with, the effects of its trajectory, and
    what it has measured (seconds per stage, the checks between rows). A new one for every replay:
    nothing of one replay's state leaks into the next that shares the world.

    The world's surface, obstacles and default vehicle are reached as attributes of the run.
    ``turret_moves``: the trajectory gives turret or gun angles (the gun's checks run only then).
    ``vehicles``: the exercise's vehicle-against-vehicle checks (``replay.vehicles.VehicleContacts``),
    when the trajectory has entities."""

    world: World
    options: ReplayOptions
    turret_moves: bool
    seconds: dict = field(default_factory=lambda: {"matching": 0.0, "terrain": 0.0, "obstacles": 0.0,
                                                   "internal": 0.0})
    between: object = None  # replay.between_rows.BetweenCounts (continuous only)
    vehicles: object = None

    def __post_init__(self):
        if self.options.continuous and self.between is None:
            from tankcd_cli.replay.between_rows import BetweenCounts

            self.between = BetweenCounts()
            self.seconds["between"] = 0.0
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
        return Effects(*(any(getattr(e, f) for e in met) for f in ("terrain_contact", "obstacles", "internal")))

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
    in time order across vehicles (``replay.vehicles.OrderCheck``), so the vehicles' checks stream;
    else their segments are spilled to disk and checked at the end."""
    run = ReplayRun(world, options, turret_moves)
    if entities:
        from tankcd_cli.replay.vehicles import VehicleContacts

        run.vehicles = VehicleContacts(world, continuous=options.continuous, source=source, ordered=ordered)
        run.seconds["vehicles"] = 0.0
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
    import dataclasses

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
        from tankcd_cli.replay.between_rows import Rows, check_between

        t0 = time.perf_counter()
        for kind, idx, part, kposes, (terrain, obstacle, internal) in parts:
            rows = Rows(part.step, part.t, part.x, part.y, part.yaw_deg, part.turret_deg, part.gun_deg, kposes,
                        obstacle, internal, terrain, _codes(part),
                        part.piece_start if part.piece_start is not None else _first_rows(part))
            table = _with_carry(run, rows)
            result = check_between(table, kind, run, run.between, want_segments=run.vehicles is not None)
            events += [Event(e.step, e.t, e.kind, e.a, e.b, e.extra, e.entity) for e in result.events]
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
    """The rows of one kind of vehicle: their poses, the events at them, and their contacts
    (terrain (N,), obstacle (N, k), internal (N,) bool)."""
    t0 = time.perf_counter()
    poses = match(run.surface, kind.vehicle, chunk.x, chunk.y, np.radians(chunk.yaw_deg), matcher=run.matcher,
                  escalate=run.escalate, tolerance=run.tolerance, attitude_tolerance=run.attitude_tolerance)
    run.seconds["matching"] += time.perf_counter() - t0
    codes = _codes(chunk)
    events = []
    off = np.flatnonzero(poses.status != OK)
    for i in off:
        events.append(Event(int(chunk.step[i]), float(chunk.t[i]), "off_terrain", "vehicle", "terrain",
                            {"status": "off" if poses.status[i] == OFF else "partly_off"}, int(codes[i])))
    good = np.flatnonzero(poses.status != OFF)
    n = len(chunk)
    where = {int(s): i for i, s in enumerate(chunk.step)} if n else {}
    terrain = np.zeros(n, dtype=bool)
    obstacle = np.zeros((n, len(run.obstacles)), dtype=bool)
    internal = np.zeros(n, dtype=bool)
    effects = run.effects_of(kind)
    if effects.terrain_contact and len(good):
        t0 = time.perf_counter()
        found = _hull_bottom(run, kind, chunk, poses, good)
        terrain[[where[e.step] for e in found]] = True
        events += found
        run.seconds["terrain"] += time.perf_counter() - t0
    if effects.obstacles and len(good):
        t0 = time.perf_counter()
        found = _obstacles(run, kind, chunk, poses, good, poses.rotation[good])
        names = {ob.name: j for j, ob in enumerate(run.obstacles)}
        for e in found:
            obstacle[where[e.step], names[e.b]] = True
        events += found
        run.seconds["obstacles"] += time.perf_counter() - t0
    if effects.internal:
        t0 = time.perf_counter()
        found = _internal(run, kind, chunk)
        internal[[where[e.step] for e in found]] = True
        events += found
        run.seconds["internal"] += time.perf_counter() - t0
    return poses, events, (terrain, obstacle, internal)


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
    from tankcd_cli.replay.between_rows import Rows

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
    from tankcd_cli.replay.between_rows import Rows

    if len(table) == 0:
        return
    last = np.flatnonzero(np.append(table.entity[1:] != table.entity[:-1], True))
    codes = table.entity[last]
    rows = table.take(last)
    rows.obstacle = rows.obstacle | swept_into[last]
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
    from tankcd_cli.replay.between_rows import ROW_FIELDS

    for f in ROW_FIELDS:
        getattr(base, f)[codes] = getattr(rows, f)
    for f in Poses.__dataclass_fields__:
        getattr(base.poses, f)[codes] = getattr(rows.poses, f)
    has[codes] = True
    run.carry = _Carry(base, has)


def _hull_bottom(run, kind, chunk, poses, idx):
    from tankcd_cli.collision.terrain_contact import hull_bottom_contacts

    hit, depth = hull_bottom_contacts(run.surface, kind.vehicle, chunk.x[idx], chunk.y[idx], poses.yaw[idx],
                                      poses.plane[idx], poses.roll[idx], poses.pitch[idx], HULL_CONTACT_TOLERANCE)
    codes = _codes(chunk)
    return [Event(int(chunk.step[idx[k]]), float(chunk.t[idx[k]]), "terrain", "hull", "terrain",
                  {"depth": round(float(d), 4)}, int(codes[idx[k]])) for k, d in zip(hit, depth)]


def _obstacles(run, kind, chunk, poses, idx, rotation):
    from tankcd_cli.collision.obstacles import collide_obstacles

    body = kind.body
    hits = collide_obstacles(body, run.obstacles, rotation, poses.position[idx],
                             np.radians(chunk.turret_deg[idx]), np.radians(chunk.gun_deg[idx]))
    codes = _codes(chunk)
    return [Event(int(chunk.step[idx[p]]), float(chunk.t[idx[p]]), "obstacle", body.part_names[part],
                  run.obstacles[o].name, {"point": [round(float(c), 4) for c in point], "contacts": int(n)},
                  int(codes[idx[p]]))
            for p, o, part, point, n in zip(hits.pose, hits.obstacle, hits.part, hits.point, hits.contacts)]


def _internal(run, kind, chunk):
    from tankcd_cli.collision.internal import DRUMS, gun_hits_drums

    hit = gun_hits_drums(kind.vehicle, np.radians(chunk.turret_deg), np.radians(chunk.gun_deg))
    rows, drums = np.nonzero(hit)
    codes = _codes(chunk)
    return [Event(int(chunk.step[r]), float(chunk.t[r]), "internal", "gun", DRUMS[d],
                  {"turret_deg": round(float(chunk.turret_deg[r]), 3), "gun_deg": round(float(chunk.gun_deg[r]), 3)},
                  int(codes[r]))
            for r, d in zip(rows, drums)]
