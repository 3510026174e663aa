"""The streaming replay pipeline: trajectory chunks in, pose chunks and events out.

Per chunk (vectorized within it): match the poses, then only the effects the
scene calls for (``Scene.effects``): the hull bottom against the terrain
always; the vehicle against obstacles only if the scene has obstacles (broad
phase on world boxes first); the gun against the rear drums only if drums are
fitted and the trajectory moves the turret or gun. Work a scene does not call
for costs nothing: no tree is loaded, no column computed.

Memory is bounded by the chunk (65 536 rows by default: a few tens of MB of
arrays) plus the terrain and trees, whatever the trajectory's length.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from tankcd_cli.matching.match import OFF, OK, Poses, match
from tankcd_cli.tolerances import HULL_CONTACT as HULL_CONTACT_TOLERANCE
from tankcd_cli.vehicle import Vehicle


@dataclass
class Event:
    step: int
    t: float
    kind: str
    a: str
    b: str
    extra: dict = field(default_factory=dict)


@dataclass
class ReplaySetup:
    """Everything a replay needs, loaded once: the terrain surface, the vehicle, and per effect its data."""

    surface: object
    vehicle: Vehicle
    effects: dict
    obstacles: list = field(default_factory=list)
    body: object = None  # collision.vehicle_body.VehicleBody: the vehicle's moving parts (with obstacles)
    seconds: dict = field(default_factory=lambda: {"matching": 0.0, "terrain": 0.0, "obstacles": 0.0, "internal": 0.0})
    escalate: bool | None = None  # key-point poses that fail the reference's certificate go to it (None: auto's)
    tolerance: float | None = None  # the certificate's tolerance, m (None: derived from the vehicle)
    continuous: bool = True  # check every effect along the motion between rows too (False: --discrete)
    between: object = None  # replay.between_rows.BetweenCounts of this replay (continuous only)


def prepare(surface, vehicle: Vehicle, scene=None, turret_moves: bool = False,
            progress: Callable[[str], None] | None = None) -> ReplaySetup:
    """Load only what the scene's effects need."""
    from tankcd_cli.scene import effects_of

    effects = effects_of(scene, vehicle, turret_moves)
    setup = ReplaySetup(surface, vehicle, effects)
    if effects["obstacles"]:
        from tankcd_cli.collision.obstacles import load_obstacles, scene_vehicle_body

        setup.obstacles = load_obstacles(scene, cache=True, progress=progress)
        warn_obstacles_beside(scene.path, setup.obstacles, surface)
        setup.body = scene_vehicle_body(scene)
    return setup


def warn_obstacles_beside(source: str, obstacles: list, surface) -> None:
    """A warning for each obstacle whose bounds miss the terrain's: it can never be hit (the
    likeliest cause, a position without the terrain's offset, such as a UTM easting)."""
    from tankcd_cli.errors import warn

    lo, hi = surface.bounds()
    for ob in obstacles:
        if ob.hi[0] < lo[0] or ob.lo[0] > hi[0] or ob.hi[1] < lo[1] or ob.lo[1] > hi[1]:
            warn(source, f"obstacle {ob.name!r} lies off the terrain: it spans x {ob.lo[0]:.1f} to {ob.hi[0]:.1f}, "
                         f"y {ob.lo[1]:.1f} to {ob.hi[1]:.1f}; the terrain x {lo[0]:.1f} to {hi[0]:.1f}, "
                         f"y {lo[1]:.1f} to {hi[1]:.1f} (is its position in the terrain's coordinates?)")


def replay_chunks(setup: ReplaySetup, chunks, matcher: str = "auto") -> Iterator[tuple[object, Poses, list]]:
    """Match every trajectory chunk and run the enabled effects at the rows and, unless the setup
    is discrete, along the motion between them (``replay.between_rows``); yields (chunk, poses,
    events) in order, events sorted by step and time."""
    carry = None
    if setup.continuous and setup.between is None:
        from tankcd_cli.replay.between_rows import BetweenCounts

        setup.between = BetweenCounts()
    for chunk in chunks:
        t0 = time.perf_counter()
        poses = match(setup.surface, setup.vehicle, chunk.x, chunk.y, np.radians(chunk.yaw_deg), matcher=matcher,
                      escalate=setup.escalate, tolerance=setup.tolerance)
        setup.seconds["matching"] += time.perf_counter() - t0
        events = []
        off = np.flatnonzero(poses.status != OK)
        for i in off:
            events.append(Event(int(chunk.step[i]), float(chunk.t[i]), "off_terrain", "vehicle", "terrain",
                                {"status": "off" if poses.status[i] == OFF else "partly_off"}))
        good = np.flatnonzero(poses.status != OFF)
        n = len(chunk)
        terrain = np.zeros(n, dtype=bool)
        obstacle = np.zeros((n, len(setup.obstacles)), dtype=bool)
        internal = np.zeros(n, dtype=bool)
        if setup.effects["terrain_contact"] and len(good):
            t0 = time.perf_counter()
            found = _hull_bottom(setup, chunk, poses, good)
            terrain[[e.step - chunk.step[0] for e in found]] = True
            events += found
            setup.seconds["terrain"] += time.perf_counter() - t0
        if setup.effects["obstacles"] and len(good):
            t0 = time.perf_counter()
            found = _obstacles(setup, chunk, poses, good, poses.rotation[good])
            names = {ob.name: j for j, ob in enumerate(setup.obstacles)}
            for e in found:
                obstacle[e.step - chunk.step[0], names[e.b]] = True
            events += found
            setup.seconds["obstacles"] += time.perf_counter() - t0
        if setup.effects["internal"]:
            t0 = time.perf_counter()
            found = _internal(setup, chunk)
            internal[[e.step - chunk.step[0] for e in found]] = True
            events += found
            setup.seconds["internal"] += time.perf_counter() - t0
        if setup.continuous:
            from tankcd_cli.replay.between_rows import Rows, check_between

            t0 = time.perf_counter()
            rows = Rows(chunk.step, chunk.t, chunk.x, chunk.y, chunk.yaw_deg, chunk.turret_deg, chunk.gun_deg, poses,
                        obstacle, internal, terrain)
            both = rows if carry is None else Rows.join(carry, rows)
            between, ending = check_between(both, setup, matcher, setup.between)
            events += [Event(e.step, e.t, e.kind, e.a, e.b, e.extra) for e in between]
            carry = rows.last()
            carry.obstacle[0] |= ending  # the next chunk's first stretch continues a contact of the last
            setup.seconds["between"] = setup.seconds.get("between", 0.0) + time.perf_counter() - t0
        events.sort(key=lambda e: (e.step, e.t))
        yield chunk, poses, events


def _hull_bottom(setup, chunk, poses, idx):
    from tankcd_cli.collision.terrain_contact import hull_bottom_contacts

    hit, depth = hull_bottom_contacts(setup.surface, setup.vehicle, chunk.x[idx], chunk.y[idx], poses.yaw[idx],
                                      poses.plane[idx], poses.roll[idx], poses.pitch[idx], HULL_CONTACT_TOLERANCE)
    return [Event(int(chunk.step[idx[k]]), float(chunk.t[idx[k]]), "terrain", "hull", "terrain",
                  {"depth": round(float(d), 4)}) for k, d in zip(hit, depth)]


def _obstacles(setup, chunk, poses, idx, rotation):
    from tankcd_cli.collision.obstacles import collide_obstacles

    hits = collide_obstacles(setup.body, setup.obstacles, rotation, poses.position[idx],
                             np.radians(chunk.turret_deg[idx]), np.radians(chunk.gun_deg[idx]))
    return [Event(int(chunk.step[idx[p]]), float(chunk.t[idx[p]]), "obstacle", setup.body.part_names[part],
                  setup.obstacles[o].name, {"point": [round(float(c), 4) for c in point], "contacts": int(n)})
            for p, o, part, point, n in zip(hits.pose, hits.obstacle, hits.part, hits.point, hits.contacts)]


def _internal(setup, chunk):
    from tankcd_cli.collision.internal import DRUMS, gun_hits_drums

    hit = gun_hits_drums(setup.vehicle, np.radians(chunk.turret_deg), np.radians(chunk.gun_deg))
    rows, drums = np.nonzero(hit)
    return [Event(int(chunk.step[r]), float(chunk.t[r]), "internal", "gun", DRUMS[d],
                  {"turret_deg": round(float(chunk.turret_deg[r]), 3), "gun_deg": round(float(chunk.gun_deg[r]), 3)})
            for r, d in zip(rows, drums)]
