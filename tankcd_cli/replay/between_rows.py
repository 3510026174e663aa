"""The effects between two rows: every contact that begins along the motion (``geometry.motion``).

For each interval between consecutive rows of a vehicle (rows with the same ``t`` have none), the
ground places the hull at the interval's sub-steps (at most ``substep_travel`` of travel and 1 deg
of turn apart: docs/formats.md#motion-between-rows), and then, for the effects the scene calls for:

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


SUBSTEP_BLOCK = 131072  # sub-steps placed and checked at once (a block of whole intervals)
ROW_FIELDS = ("step", "t", "x", "y", "yaw_deg", "turret_deg", "gun_deg", "obstacle", "internal", "terrain",
              "entity", "piece_start", "carried")


@dataclass
class Rows:
    """Rows of vehicles of one kind with their poses and the contacts found at them (N of each), each
    vehicle's rows together and in time order (the motion runs between consecutive rows of one
    vehicle, ``entity``, unless the later starts a new piece of motion).

    step, t, x, y, yaw_deg, turret_deg, gun_deg : (N,) the trajectory's columns
    poses : the rows' matched poses (``matching.match.Poses``)
    obstacle : (N, obstacles) bool, in contact with each obstacle at the row
    internal : (N,) bool, the gun touching a drum at the row
    terrain : (N,) bool, the hull bottom on the ground at the row
    entity : (N,) int64, the vehicle's code (0 for a single vehicle)
    piece_start : (N,) bool, no motion into this row from the vehicle's previous one
    carried : (N,) bool, a row carried from an earlier chunk (the motion before it was checked there)
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
    entity: np.ndarray = None
    piece_start: np.ndarray = None
    carried: np.ndarray = None

    def __post_init__(self):
        if self.entity is None:
            self.entity = np.zeros(len(self.t), dtype=np.int64)
        if self.piece_start is None:
            self.piece_start = np.zeros(len(self.t), dtype=bool)
        if self.carried is None:
            self.carried = np.zeros(len(self.t), dtype=bool)

    def __len__(self) -> int:
        return len(self.t)

    def take(self, idx: np.ndarray) -> "Rows":
        p = self.poses
        poses = Poses(*(getattr(p, f)[idx] for f in Poses.__dataclass_fields__))
        return Rows(poses=poses, **{f: getattr(self, f)[idx] for f in ROW_FIELDS})

    @staticmethod
    def join(parts: list) -> "Rows":
        poses = Poses(*(np.concatenate([getattr(r.poses, f) for r in parts]) for f in Poses.__dataclass_fields__))
        return Rows(poses=poses, **{f: np.concatenate([getattr(r, f) for r in parts]) for f in ROW_FIELDS})

    @property
    def links(self) -> np.ndarray:
        """(N - 1,) bool: the motion runs from each row to the next (same vehicle, no new piece)."""
        return (self.entity[1:] == self.entity[:-1]) & ~self.piece_start[1:]


@dataclass
class Segments:
    """The rigid sub-steps of the motion, M of them, each between two placements both on the terrain:
    entity (M,) the vehicle's code, step (M,) the step of the row its interval starts at, t0, t1 (M,)
    its time span (s), q0, c0, q1, c1 the hull's attitude (M, 4) and origin (M, 3) at its ends,
    turret0, dturret, gun0, dgun (M,) the turret's and gun's angles at its start and their
    changes over it (rad), fresh (M,) bool: it starts a piece of its vehicle's motion (no motion
    before it: the vehicle's first row, or a new piece). What the vehicles' checks against each
    other take."""

    entity: np.ndarray
    step: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    q0: np.ndarray
    c0: np.ndarray
    q1: np.ndarray
    c1: np.ndarray
    turret0: np.ndarray
    dturret: np.ndarray
    gun0: np.ndarray
    dgun: np.ndarray
    fresh: np.ndarray

    def __len__(self) -> int:
        return len(self.t0)

    def take(self, idx) -> "Segments":
        return Segments(*(getattr(self, f)[idx] for f in self.__dataclass_fields__))

    @staticmethod
    def join(parts: list) -> "Segments":
        return Segments(*(np.concatenate([getattr(p, f) for p in parts]) for f in Segments.__dataclass_fields__))


@dataclass
class BetweenResult:
    """What the checks between rows found: the events, per row and obstacle whether the stretch of
    motion ending at the row touched the obstacle (N, obstacles), and the motion's rigid segments
    (when asked for)."""

    events: list
    swept_into: np.ndarray
    segments: Segments | None = None


@dataclass(frozen=True)
class BetweenEvent:
    """A contact that begins between two rows: the earlier row's step, the time of first contact,
    the kind and the two parts, what the kind carries (point, depth, angles, status) and the
    vehicle's code."""

    step: int
    t: float
    kind: str
    a: str
    b: str
    extra: dict
    entity: int = 0


@dataclass
class BetweenCounts:
    """What the checks between rows did: intervals, sub-steps placed, and events per kind."""

    intervals: int = 0
    substeps: int = 0
    events: dict = None

    def __post_init__(self):
        if self.events is None:
            self.events = {"obstacle": 0, "internal": 0, "terrain": 0, "off_terrain": 0}


def check_between(rows: Rows, kind, run, counts: BetweenCounts, want_segments: bool = False) -> BetweenResult:
    """The events that begin between consecutive rows of ``rows`` (vehicles of one kind: ``kind``
    gives their ``vehicle`` and moving parts, ``body``), for the effects ``run``
    (``replay.pipeline.ReplayRun``) enables for that kind; ``counts`` is updated."""
    iv = row_intervals(rows.t, rows.x, rows.y, rows.yaw_deg, rows.turret_deg, rows.gun_deg, links=rows.links)
    swept_into = np.zeros(rows.obstacle.shape, dtype=bool)
    if len(iv) == 0:
        return BetweenResult([], swept_into, _no_segments() if want_segments else None)
    a_all = iv.first
    b_all = a_all + 1
    # only intervals whose both rows have a pose carry a motion the ground defines
    placed_all = (rows.poses.status[a_all] != OFF) & (rows.poses.status[b_all] != OFF)
    counts.intervals += int(placed_all.sum())
    n_all = substep_counts(iv.travel, iv.dyaw, substep_travel(run.surface), MAX_TURN_DEG)
    n_all = np.where(placed_all, n_all, 1)
    counts.substeps += int(np.maximum(n_all - 1, 0).sum())
    # an interval starts a piece when no motion leads into its first row: that row starts a piece,
    # or no interval of the table ends there and it is not carried from the chunk before
    piece_first_all = rows.piece_start[a_all] | (~np.isin(a_all, b_all) & ~rows.carried[a_all])
    events: list[BetweenEvent] = []
    effects = run.effects_of(kind)
    parts = []
    # intervals in blocks of at most SUBSTEP_BLOCK sub-steps (an interval whole in one), so that the
    # sub-steps' placements and segments take memory by the block, not by the rows' spacing: a
    # chunk of sparse rows (1 Hz, seconds apart) holds ten times the sub-steps of a 10 Hz one
    for block in _interval_blocks(n_all, SUBSTEP_BLOCK):
        ivb = iv.take(block)
        a, b, n, placed = a_all[block], b_all[block], n_all[block], placed_all[block]
        owner, frac = substeps(ivb, n)
        at = ivb.at(owner, frac)
        sub = match(run.surface, kind.vehicle, at["x"], at["y"], np.radians(at["yaw_deg"]), matcher=run.matcher,
                    escalate=run.escalate, tolerance=run.tolerance,
                    attitude_tolerance=run.attitude_tolerance, measure=False, regions=run.matcher == "auto")
        # each interval's sequence of placements: its first row, its sub-steps, its second row
        first_sub = np.cumsum(n - 1) - (n - 1)
        if effects.terrain_contact:
            events += _terrain(rows, kind, run, ivb, a, owner, frac, at, sub, placed)
        segments = _segments(rows, ivb, a, b, n, first_sub, sub, placed)
        if effects.obstacles and run.obstacles:
            found, swept = _obstacles(rows, kind, run, ivb, a, b, n, first_sub, at, sub, segments)
            events += found
            swept_into |= swept
        if effects.internal:
            events += _internal(rows, kind, ivb, a)
        if want_segments:
            parts.append(_public_segments(rows, ivb, a, segments, piece_first_all[block]))
    for e in events:
        counts.events[e.kind] += 1
    events.sort(key=lambda e: (e.step, e.t))
    public = None
    if want_segments:
        public = Segments.join(parts) if len(parts) > 1 else parts[0] if parts else _no_segments()
    return BetweenResult(events, swept_into, public)


def _interval_blocks(n: np.ndarray, limit: int) -> list:
    """Slices of consecutive intervals whose sub-step counts ``n`` sum to at most ``limit`` each (an
    interval with more is a block of its own); one slice for all when they fit."""
    total = np.cumsum(n)
    if len(n) == 0 or total[-1] <= limit:
        return [slice(0, len(n))]
    blocks, start = [], 0
    while start < len(n):
        base = total[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(total, base + limit, side="right")))
        blocks.append(slice(start, stop))
        start = stop
    return blocks


def _public_segments(rows, iv, a, segments, piece_first) -> Segments:
    """The placed rigid segments of a block of intervals, as the checks between vehicles take them."""
    ok = segments["use"]
    i = segments["seg_iv"][ok]
    f0, f1 = segments["f0"][ok], segments["f1"][ok]
    fresh = (segments["seg_k"][ok] == 0) & piece_first[i]
    return Segments(rows.entity[a[i]], rows.step[a[i]], iv.t0[i] + f0 * iv.dt[i], iv.t0[i] + f1 * iv.dt[i],
                    segments["q0"][ok], segments["c0"][ok], segments["q1"][ok], segments["c1"][ok],
                    np.radians(iv.turret0[i] + f0 * iv.dturret[i]), np.radians((f1 - f0) * iv.dturret[i]),
                    np.radians(iv.gun0[i] + f0 * iv.dgun[i]), np.radians((f1 - f0) * iv.dgun[i]), fresh)


def _no_segments() -> Segments:
    z = np.zeros(0)
    return Segments(np.zeros(0, np.int64), np.zeros(0, np.int64), z, z, np.zeros((0, 4)), np.zeros((0, 3)),
                    np.zeros((0, 4)), np.zeros((0, 3)), z, z, z, z, np.zeros(0, dtype=bool))


def _segments(rows, iv, a, b, n, first_sub, sub, placed) -> dict:
    """Every interval's rigid sub-steps: for interval i, placements 0 .. n_i (0 the row a, n_i the row
    b, between them the sub-steps); each segment's ends, where they come from and whether both are
    placed (``use``)."""
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
    use = placed[seg_iv] & (status[start] != OFF) & (status[end] != OFF)
    return {"seg_iv": seg_iv, "seg_k": seg_k, "start": start, "end": end, "use": use,
            "q0": quat[start], "c0": pos[start], "q1": quat[end], "c1": pos[end],
            "f0": seg_k / n[seg_iv], "f1": (seg_k + 1) / n[seg_iv]}


def _terrain(rows, kind, run, iv, a, owner, frac, at, sub, placed):
    """The hull bottom at every sub-step; an event where contact (or leaving the terrain) begins."""
    from tankcd_cli.collision.terrain_contact import hull_bottom_contacts
    from tankcd_cli.tolerances import HULL_CONTACT

    good = np.flatnonzero((sub.status != OFF) & placed[owner])
    hit = np.zeros(len(owner), dtype=bool)
    depth = np.zeros(len(owner))
    if len(good):
        k, d = hull_bottom_contacts(run.surface, kind.vehicle, at["x"][good], at["y"][good], sub.yaw[good],
                                    sub.plane[good], sub.roll[good], sub.pitch[good], HULL_CONTACT)
        hit[good[k]] = True
        depth[good[k]] = d
    before = np.empty(len(owner), dtype=bool)  # in contact at the placement before each sub-step
    if len(owner):
        before[1:] = hit[:-1]
        starts = np.flatnonzero(np.diff(owner, prepend=-1) != 0)
        before[starts] = rows.terrain[a[owner[starts]]]
    events = [BetweenEvent(int(rows.step[a[owner[i]]]), float(at["t"][i]), "terrain", "hull", "terrain",
                           {"depth": round(float(depth[i]), 4), "between": True}, int(rows.entity[a[owner[i]]]))
              for i in np.flatnonzero(hit & ~before)]
    # a path that leaves the terrain between two rows on it: the first sub-step off, per interval
    off = (sub.status != OK) & placed[owner] & (rows.poses.status[a[owner]] == OK) & \
        (rows.poses.status[a[owner] + 1] == OK)
    _, first_off = np.unique(owner[off], return_index=True)  # the first sub-step off, per interval
    for i in np.flatnonzero(off)[first_off]:
        events.append(BetweenEvent(int(rows.step[a[owner[i]]]), float(at["t"][i]), "off_terrain", "vehicle",
                                   "terrain", {"status": "off" if sub.status[i] == OFF else "partly_off",
                                               "between": True}, int(rows.entity[a[owner[i]]])))
    return events


def _obstacles(rows, kind, run, iv, a, b, n, first_sub, at, sub, segments):
    """Every rigid sub-step of every interval against the obstacles; an event per (sub-step,
    obstacle) where a contact begins (the sub-step's start not already touching that obstacle)."""
    from tankcd_cli.collision.obstacles import collide_obstacles, obstacles_along

    body, obstacles = kind.body, run.obstacles
    k = len(obstacles)
    nrows = len(rows)
    swept_into = np.zeros((nrows, k), dtype=bool)
    # the sub-steps' own contacts (the rows' are known), for the state at each segment's start
    sub_touch = np.zeros((len(sub), k), dtype=bool)
    ok_sub = np.flatnonzero(sub.status != OFF)
    if len(ok_sub):
        hits = collide_obstacles(body, obstacles, sub.rotation[ok_sub], sub.position[ok_sub],
                                 np.radians(at["turret_deg"][ok_sub]), np.radians(at["gun_deg"][ok_sub]))
        sub_touch[ok_sub[hits.pose], hits.obstacle] = True
    seg_iv, seg_k, f0, f1 = segments["seg_iv"], segments["seg_k"], segments["f0"], segments["f1"]
    touch0 = np.concatenate([rows.obstacle, sub_touch])[segments["start"]]
    use = np.flatnonzero(segments["use"])
    if len(use) == 0:
        return [], swept_into
    i = seg_iv[use]
    turret0 = np.radians(iv.turret0[i] + f0[use] * iv.dturret[i])
    gun0 = np.radians(iv.gun0[i] + f0[use] * iv.dgun[i])
    dturret = np.radians((f1[use] - f0[use]) * iv.dturret[i])
    dgun = np.radians((f1[use] - f0[use]) * iv.dgun[i])
    swept = obstacles_along(body, obstacles, segments["q0"][use], segments["c0"][use], segments["q1"][use],
                            segments["c1"][use], turret0, dturret, gun0, dgun)
    touched = np.zeros((len(seg_iv), k), dtype=bool)
    touched[use[swept.step], swept.obstacle] = True
    # a segment continues the one before it where that one ends at its start: within an interval,
    # or from the last of the interval before when it ends at this interval's first row
    follows = np.zeros(len(seg_iv), dtype=bool)
    follows[1:] = (seg_k[1:] > 0) | (a[seg_iv[1:]] == b[seg_iv[:-1]])
    touch0[1:] |= touched[:-1] & follows[1:, None]
    last_of_interval = np.flatnonzero(np.append(seg_iv[1:] != seg_iv[:-1], True))
    swept_into[b[seg_iv[last_of_interval]]] = touched[last_of_interval]
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
                                   {"point": [round(float(c), 4) for c in point], "between": True},
                                   int(rows.entity[a[ivx]])))
    return events, swept_into


def _internal(rows, kind, iv, a):
    """The gun along each interval's angle path, for intervals whose first row is clear of the drums."""
    from tankcd_cli.collision.internal import DRUMS, first_gun_contacts

    moving = np.flatnonzero(((iv.dturret != 0) | (iv.dgun != 0)) & ~rows.internal[a])
    if len(moving) == 0:
        return []
    found, s, drum = first_gun_contacts(kind.vehicle, np.radians(iv.turret0[moving]), np.radians(iv.dturret[moving]),
                                        np.radians(iv.gun0[moving]), np.radians(iv.dgun[moving]))
    events = []
    for j in np.flatnonzero(found & (s > 0)):
        k = moving[j]
        turret = iv.turret0[k] + s[j] * iv.dturret[k]
        turret = (turret + 180.0) % 360.0 - 180.0
        events.append(BetweenEvent(int(rows.step[a[k]]), float(iv.t0[k] + s[j] * iv.dt[k]), "internal", "gun",
                                   DRUMS[drum[j]], {"turret_deg": round(float(turret), 3),
                                                    "gun_deg": round(float(iv.gun0[k] + s[j] * iv.dgun[k]), 3),
                                                    "between": True}, int(rows.entity[a[k]])))
    return events
