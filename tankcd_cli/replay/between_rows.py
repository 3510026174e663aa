"""The effects between two rows: every contact that begins along the motion (``geometry.motion``).

For each interval between consecutive rows of a vehicle (rows with the same ``t`` have none), the
ground places the hull at the interval's sub-steps (at most ``substep_travel`` of travel and 1 deg
of turn apart, the contract's resolution), and then, for the effects the scene calls for:

- the hull bottom against the terrain: the exact pass of the rows at every sub-step;
- obstacles: exact along each rigid sub-step (``collision.obstacles.obstacles_along``: never
  missed, a pass within 1 mm may count, the time to 0.5 mm of travel);
- the gun against the drums: along the straight path in (azimuth, elevation) to 0.005 deg
  (``collision.internal.first_gun_contacts``).

A contact that *begins* between two rows is one event: ``step`` the earlier row, ``t`` the time of
first contact (t_i < t <= t_i+1), ``"between": true``. A contact already present where a stretch of
motion starts is a continuing contact and gives none: rows report their own contacts as before, so
a contact present at both rows is reported at the rows only. For obstacles a stretch starts in
contact when the vehicle touches the obstacle there or touched it during the stretch before (a post
that passes wholly inside the hull's shell touches no triangle for a while: it is still one
contact, not a new one where it leaves). Within one stretch that starts in contact, a separation
and a new contact of the same pair before the next sub-step is not reported apart (it is the same
episode at the resolution used).

Memory and order: a chunk's intervals are handled together (vectorised); the last row of a chunk,
its pose and its contacts are carried into the next chunk (``Carry``), so an interval straddling a
chunk boundary is checked once, by the later chunk, under the earlier row's step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.geometry.motion import MAX_TURN_DEG, MESH_TRAVEL, row_intervals, substep_counts, substeps
from tankcd_cli.matching.match import OFF, OK, Poses, match


def substep_travel(surface) -> float:
    """The largest travel between two sub-steps, m: half the post spacing on a grid, 0.25 m on meshes."""
    spacing = getattr(surface, "spacing", None)
    return float(np.min(spacing)) / 2 if spacing is not None else MESH_TRAVEL


def resolution(surface) -> dict:
    """The resolution of the checks between rows, as the summary states it."""
    from tankcd_cli.bvh.sweep import LEAF_BOUND
    from tankcd_cli.collision.internal import GUN_PATH_STEP_DEG

    return {"substep_travel_m": round(substep_travel(surface), 6), "substep_turn_deg": MAX_TURN_DEG,
            "obstacle_pass_m": 2 * LEAF_BOUND, "obstacle_time_travel_m": LEAF_BOUND, "gun_step_deg": GUN_PATH_STEP_DEG}


@dataclass
class Rows:
    """Consecutive rows of one vehicle with their poses and the contacts found at them (N of each).

    step, t, x, y, yaw_deg, turret_deg, gun_deg : (N,) the trajectory's columns
    poses : the rows' matched poses (``matching.match.Poses``)
    obstacle : (N, obstacles) bool, in contact with each obstacle at the row
    internal : (N,) bool, the gun touching a drum at the row
    terrain : (N,) bool, the hull bottom on the ground at the row
    """

    step: np.ndarray
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw_deg: np.ndarray
    turret_deg: np.ndarray
    gun_deg: np.ndarray
    poses: Poses
    obstacle: np.ndarray
    internal: np.ndarray
    terrain: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def last(self) -> "Rows":
        return self.take(np.array([len(self) - 1]))

    def take(self, idx: np.ndarray) -> "Rows":
        p = self.poses
        poses = Poses(*(getattr(p, f)[idx] for f in Poses.__dataclass_fields__))
        return Rows(self.step[idx], self.t[idx], self.x[idx], self.y[idx], self.yaw_deg[idx], self.turret_deg[idx],
                    self.gun_deg[idx], poses, self.obstacle[idx], self.internal[idx], self.terrain[idx])

    @staticmethod
    def join(a: "Rows", b: "Rows") -> "Rows":
        pa, pb = a.poses, b.poses
        poses = Poses(*(np.concatenate([getattr(pa, f), getattr(pb, f)]) for f in Poses.__dataclass_fields__))
        cat = {f: np.concatenate([getattr(a, f), getattr(b, f)])
               for f in ("step", "t", "x", "y", "yaw_deg", "turret_deg", "gun_deg", "obstacle", "internal", "terrain")}
        return Rows(poses=poses, **cat)


@dataclass(frozen=True)
class BetweenEvent:
    """A contact that begins between two rows: the earlier row's step, the time of first contact,
    the kind and the two parts, and what the kind carries (point, depth, angles, status)."""

    step: int
    t: float
    kind: str
    a: str
    b: str
    extra: dict


@dataclass
class BetweenCounts:
    """What the checks between rows did: intervals, sub-steps placed, and events per kind."""

    intervals: int = 0
    substeps: int = 0
    events: dict = None

    def __post_init__(self):
        if self.events is None:
            self.events = {"obstacle": 0, "internal": 0, "terrain": 0, "off_terrain": 0}


def check_between(rows: Rows, run, matcher: str, counts: BetweenCounts) -> tuple[list[BetweenEvent], np.ndarray]:
    """The events that begin between consecutive rows of ``rows`` (one vehicle), for the effects
    ``run`` (``replay.pipeline.ReplayRun``) enables; ``counts`` is updated. Also returns, per
    obstacle (k,), whether the stretch of motion ending at the last row touched it (the state the
    next chunk's first stretch starts from, with the last row's own contacts)."""
    iv = row_intervals(rows.t, rows.x, rows.y, rows.yaw_deg, rows.turret_deg, rows.gun_deg)
    ending = np.zeros(rows.obstacle.shape[1], dtype=bool)
    if len(iv) == 0:
        return [], ending
    a = iv.first
    b = a + 1
    # only intervals whose both rows have a pose carry a motion the ground defines
    placed = (rows.poses.status[a] != OFF) & (rows.poses.status[b] != OFF)
    counts.intervals += int(placed.sum())
    n = substep_counts(iv.travel, iv.dyaw, substep_travel(run.surface), MAX_TURN_DEG)
    n = np.where(placed, n, 1)
    owner, frac = substeps(iv, n)
    counts.substeps += len(owner)
    at = iv.at(owner, frac)
    sub = match(run.surface, run.vehicle, at["x"], at["y"], np.radians(at["yaw_deg"]), matcher=matcher,
                escalate=run.escalate, tolerance=run.tolerance, measure=False,
                regions=matcher == "auto")
    # each interval's sequence of placements: its first row, its sub-steps, its second row
    first_sub = np.cumsum(n - 1) - (n - 1)
    events: list[BetweenEvent] = []
    effects = run.effects
    if effects.terrain_contact:
        events += _terrain(rows, run, iv, a, owner, frac, at, sub, placed)
    if effects.obstacles and run.obstacles:
        found, ending = _obstacles(rows, run, iv, a, b, n, first_sub, owner, frac, at, sub, placed)
        events += found
    if effects.internal:
        events += _internal(rows, run, iv, a)
    for e in events:
        counts.events[e.kind] += 1
    events.sort(key=lambda e: (e.step, e.t))
    return events, ending


def _terrain(rows, run, iv, a, owner, frac, at, sub, placed):
    """The hull bottom at every sub-step; an event where contact (or leaving the terrain) begins."""
    from tankcd_cli.collision.terrain_contact import hull_bottom_contacts
    from tankcd_cli.tolerances import HULL_CONTACT

    good = np.flatnonzero((sub.status != OFF) & placed[owner])
    hit = np.zeros(len(owner), dtype=bool)
    depth = np.zeros(len(owner))
    if len(good):
        k, d = hull_bottom_contacts(run.surface, run.vehicle, at["x"][good], at["y"][good], sub.yaw[good],
                                    sub.plane[good], sub.roll[good], sub.pitch[good], HULL_CONTACT)
        hit[good[k]] = True
        depth[good[k]] = d
    before = np.empty(len(owner), dtype=bool)  # in contact at the placement before each sub-step
    if len(owner):
        before[1:] = hit[:-1]
        starts = np.flatnonzero(np.diff(owner, prepend=-1) != 0)
        before[starts] = rows.terrain[a[owner[starts]]]
    events = [BetweenEvent(int(rows.step[a[owner[i]]]), float(at["t"][i]), "terrain", "hull", "terrain",
                           {"depth": round(float(depth[i]), 4), "between": True})
              for i in np.flatnonzero(hit & ~before)]
    # a path that leaves the terrain between two rows on it: the first sub-step off, per interval
    off = (sub.status != OK) & placed[owner] & (rows.poses.status[a[owner]] == OK) & \
        (rows.poses.status[a[owner] + 1] == OK)
    _, first_off = np.unique(owner[off], return_index=True)  # the first sub-step off, per interval
    for i in np.flatnonzero(off)[first_off]:
        events.append(BetweenEvent(int(rows.step[a[owner[i]]]), float(at["t"][i]), "off_terrain", "vehicle",
                                   "terrain", {"status": "off" if sub.status[i] == OFF else "partly_off",
                                               "between": True}))
    return events


def _obstacles(rows, run, iv, a, b, n, first_sub, owner, frac, at, sub, placed):
    """Every rigid sub-step of every interval against the obstacles; an event per (sub-step,
    obstacle) where a contact begins (the sub-step's start not already touching that obstacle)."""
    from tankcd_cli.collision.obstacles import collide_obstacles, obstacles_along

    body, obstacles = run.body, run.obstacles
    k = len(obstacles)
    # the sub-steps' own contacts (the rows' are known), for the state at each segment's start
    sub_touch = np.zeros((len(owner), k), dtype=bool)
    ok_sub = np.flatnonzero(sub.status != OFF)
    if len(ok_sub):
        hits = collide_obstacles(body, obstacles, sub.rotation[ok_sub], sub.position[ok_sub],
                                 np.radians(at["turret_deg"][ok_sub]), np.radians(at["gun_deg"][ok_sub]))
        sub_touch[ok_sub[hits.pose], hits.obstacle] = True
    # segments: for interval i, placements 0 .. n_i (0 the row a, n_i the row b, between them the sub-steps)
    seg_iv = np.repeat(np.arange(len(iv)), n)
    seg_k = np.arange(len(seg_iv)) - np.repeat(np.cumsum(n) - n, n)  # segment index within its interval
    start_is_row = seg_k == 0
    end_is_row = seg_k == n[seg_iv] - 1
    start_sub = np.where(start_is_row, -1, first_sub[seg_iv] + seg_k - 1)
    end_sub = np.where(end_is_row, -1, first_sub[seg_iv] + seg_k)
    # the placements in one table: the rows' first, then the sub-steps'
    P = rows.poses
    quat = np.concatenate([P.quaternion, sub.quaternion])
    pos = np.concatenate([P.position, sub.position])
    status = np.concatenate([P.status, sub.status])
    nrows = len(rows)
    start = np.where(start_is_row, a[seg_iv], nrows + start_sub)
    end = np.where(end_is_row, b[seg_iv], nrows + end_sub)
    q0, c0, st0 = quat[start], pos[start], status[start]
    q1, c1, st1 = quat[end], pos[end], status[end]
    f0 = seg_k / n[seg_iv]
    f1 = (seg_k + 1) / n[seg_iv]
    touch0 = np.concatenate([rows.obstacle, sub_touch])[start]
    use = np.flatnonzero(placed[seg_iv] & (st0 != OFF) & (st1 != OFF))
    ending = np.zeros(k, dtype=bool)
    if len(use) == 0:
        return [], ending
    i = seg_iv[use]
    turret0 = np.radians(iv.turret0[i] + f0[use] * iv.dturret[i])
    gun0 = np.radians(iv.gun0[i] + f0[use] * iv.dgun[i])
    dturret = np.radians((f1[use] - f0[use]) * iv.dturret[i])
    dgun = np.radians((f1[use] - f0[use]) * iv.dgun[i])
    swept = obstacles_along(body, obstacles, q0[use], c0[use], q1[use], c1[use], turret0, dturret, gun0, dgun)
    touched = np.zeros((len(seg_iv), k), dtype=bool)
    touched[use[swept.step], swept.obstacle] = True
    # a segment continues the one before it where that one ends at its start: within an interval,
    # or from the last of the interval before when it ends at this interval's first row
    follows = np.zeros(len(seg_iv), dtype=bool)
    follows[1:] = (seg_k[1:] > 0) | (a[seg_iv[1:]] == b[seg_iv[:-1]])
    touch0[1:] |= touched[:-1] & follows[1:, None]
    if b[seg_iv[-1]] == len(rows) - 1:
        ending = touched[-1]
    events = []
    for seg, o, part, s, point in zip(swept.step, swept.obstacle, swept.part, swept.s, swept.point):
        g = use[seg]
        if touch0[g, o]:
            continue  # a contact continuing from the segment's start
        ivx = seg_iv[g]
        frac_at = f0[g] + s * (f1[g] - f0[g])
        t = float(iv.t0[ivx] + frac_at * iv.dt[ivx])
        t = min(max(t, float(np.nextafter(iv.t0[ivx], np.inf))), float(iv.t0[ivx] + iv.dt[ivx]))
        events.append(BetweenEvent(int(rows.step[a[ivx]]), t, "obstacle", body.part_names[part], obstacles[o].name,
                                   {"point": [round(float(c), 4) for c in point], "between": True}))
    return events, ending


def _internal(rows, run, iv, a):
    """The gun along each interval's angle path, for intervals whose first row is clear of the drums."""
    from tankcd_cli.collision.internal import DRUMS, first_gun_contacts

    moving = np.flatnonzero(((iv.dturret != 0) | (iv.dgun != 0)) & ~rows.internal[a])
    if len(moving) == 0:
        return []
    found, s, drum = first_gun_contacts(run.vehicle, np.radians(iv.turret0[moving]), np.radians(iv.dturret[moving]),
                                        np.radians(iv.gun0[moving]), np.radians(iv.dgun[moving]))
    events = []
    for j in np.flatnonzero(found & (s > 0)):
        k = moving[j]
        turret = iv.turret0[k] + s[j] * iv.dturret[k]
        turret = (turret + 180.0) % 360.0 - 180.0
        events.append(BetweenEvent(int(rows.step[a[k]]), float(iv.t0[k] + s[j] * iv.dt[k]), "internal", "gun",
                                   DRUMS[drum[j]], {"turret_deg": round(float(turret), 3),
                                                    "gun_deg": round(float(iv.gun0[k] + s[j] * iv.dgun[k]), 3),
                                                    "between": True}))
    return events
