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

    The world's surface, vehicle, obstacles and body are reached as attributes of the run, which
    is what the effects' functions take."""

    world: World
    options: ReplayOptions
    effects: Effects
    seconds: dict = field(default_factory=lambda: {"matching": 0.0, "terrain": 0.0, "obstacles": 0.0,
                                                   "internal": 0.0})
    between: object = None  # replay.between_rows.BetweenCounts (continuous only)

    def __post_init__(self):
        if self.options.continuous and self.between is None:
            from tankcd_cli.replay.between_rows import BetweenCounts

            self.between = BetweenCounts()
            self.seconds["between"] = 0.0

    surface = property(lambda self: self.world.surface)
    vehicle = property(lambda self: self.world.vehicle)
    obstacles = property(lambda self: self.world.obstacles)
    body = property(lambda self: self.world.body)
    matcher = property(lambda self: self.options.matcher)
    escalate = property(lambda self: self.options.escalate)
    tolerance = property(lambda self: self.options.tolerance)
    continuous = property(lambda self: self.options.continuous)


def start_run(world: World, options: ReplayOptions, turret_moves: bool) -> ReplayRun:
    """A replay's run of ``world`` for a trajectory whose turret or gun moves (or not)."""
    return ReplayRun(world, options, world.effects(turret_moves))


def replay_chunks(run: ReplayRun, chunks, lead=None) -> Iterator[tuple[object, Poses, list]]:
    """Match every trajectory chunk and run the enabled effects at the rows and, unless the run is
    discrete, along the motion between them (``replay.between_rows``); yields (chunk, poses,
    events) in order, events sorted by step and time.

    lead : the row just before the first chunk (a trajectory part's ``io.trajectory.lead_row``):
        placed and checked like the others but not yielded, so that the interval from it to the
        first row is checked here, under its step, exactly once over all the parts.
    """
    carry = None
    if lead is not None and len(lead):
        _, _, _, carry = _chunk(run, lead, None)
    for chunk in chunks:
        poses, events, rows, carry = _chunk(run, chunk, carry)
        yield chunk, poses, events


def _chunk(run: ReplayRun, chunk, carry):
    """One chunk: its poses, its events (sorted), its rows and the carry for the next chunk."""
    t0 = time.perf_counter()
    poses = match(run.surface, run.vehicle, chunk.x, chunk.y, np.radians(chunk.yaw_deg), matcher=run.matcher,
                  escalate=run.escalate, tolerance=run.tolerance)
    run.seconds["matching"] += time.perf_counter() - t0
    events = []
    off = np.flatnonzero(poses.status != OK)
    for i in off:
        events.append(Event(int(chunk.step[i]), float(chunk.t[i]), "off_terrain", "vehicle", "terrain",
                            {"status": "off" if poses.status[i] == OFF else "partly_off"}))
    good = np.flatnonzero(poses.status != OFF)
    n = len(chunk)
    first_step = int(chunk.step[0]) if n else 0
    terrain = np.zeros(n, dtype=bool)
    obstacle = np.zeros((n, len(run.obstacles)), dtype=bool)
    internal = np.zeros(n, dtype=bool)
    if run.effects.terrain_contact and len(good):
        t0 = time.perf_counter()
        found = _hull_bottom(run, chunk, poses, good)
        terrain[[e.step - first_step for e in found]] = True
        events += found
        run.seconds["terrain"] += time.perf_counter() - t0
    if run.effects.obstacles and len(good):
        t0 = time.perf_counter()
        found = _obstacles(run, chunk, poses, good, poses.rotation[good])
        names = {ob.name: j for j, ob in enumerate(run.obstacles)}
        for e in found:
            obstacle[e.step - first_step, names[e.b]] = True
        events += found
        run.seconds["obstacles"] += time.perf_counter() - t0
    if run.effects.internal:
        t0 = time.perf_counter()
        found = _internal(run, chunk)
        internal[[e.step - first_step for e in found]] = True
        events += found
        run.seconds["internal"] += time.perf_counter() - t0
    rows = None
    if run.continuous and n:
        from tankcd_cli.replay.between_rows import Rows, check_between

        t0 = time.perf_counter()
        rows = Rows(chunk.step, chunk.t, chunk.x, chunk.y, chunk.yaw_deg, chunk.turret_deg, chunk.gun_deg, poses,
                    obstacle, internal, terrain)
        both = rows if carry is None else Rows.join(carry, rows)
        between, ending = check_between(both, run, run.matcher, run.between)
        events += [Event(e.step, e.t, e.kind, e.a, e.b, e.extra) for e in between]
        carry = rows.last()
        carry.obstacle[0] |= ending  # the next chunk's first stretch continues a contact of the last
        run.seconds["between"] += time.perf_counter() - t0
    events.sort(key=lambda e: (e.step, e.t))
    return poses, events, rows, carry


def _hull_bottom(run, chunk, poses, idx):
    from tankcd_cli.collision.terrain_contact import hull_bottom_contacts

    hit, depth = hull_bottom_contacts(run.surface, run.vehicle, chunk.x[idx], chunk.y[idx], poses.yaw[idx],
                                      poses.plane[idx], poses.roll[idx], poses.pitch[idx], HULL_CONTACT_TOLERANCE)
    return [Event(int(chunk.step[idx[k]]), float(chunk.t[idx[k]]), "terrain", "hull", "terrain",
                  {"depth": round(float(d), 4)}) for k, d in zip(hit, depth)]


def _obstacles(run, chunk, poses, idx, rotation):
    from tankcd_cli.collision.obstacles import collide_obstacles

    hits = collide_obstacles(run.body, run.obstacles, rotation, poses.position[idx],
                             np.radians(chunk.turret_deg[idx]), np.radians(chunk.gun_deg[idx]))
    return [Event(int(chunk.step[idx[p]]), float(chunk.t[idx[p]]), "obstacle", run.body.part_names[part],
                  run.obstacles[o].name, {"point": [round(float(c), 4) for c in point], "contacts": int(n)})
            for p, o, part, point, n in zip(hits.pose, hits.obstacle, hits.part, hits.point, hits.contacts)]


def _internal(run, chunk):
    from tankcd_cli.collision.internal import DRUMS, gun_hits_drums

    hit = gun_hits_drums(run.vehicle, np.radians(chunk.turret_deg), np.radians(chunk.gun_deg))
    rows, drums = np.nonzero(hit)
    return [Event(int(chunk.step[r]), float(chunk.t[r]), "internal", "gun", DRUMS[d],
                  {"turret_deg": round(float(chunk.turret_deg[r]), 3), "gun_deg": round(float(chunk.gun_deg[r]), 3)})
            for r, d in zip(rows, drums)]
