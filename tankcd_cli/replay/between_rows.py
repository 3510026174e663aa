"""The motion between two rows (``geometry.motion``): the rows of a chunk, their intervals, the
sub-steps that place the hull along each, and the rigid segments between those placements; the
effects' checks along the motion (``replay.effects``) run on it, a block at a time.

For each interval between consecutive rows of a vehicle (rows with the same ``t`` have none), the
ground places the hull at the interval's sub-steps (at most ``substep_travel`` of travel and 1 deg
of turn apart, the resolution docs/formats.md states); each effect the scene calls for then checks
the block (``Effect.along``): the hull bottom at every sub-step, obstacles along each rigid
sub-step, the gun along the straight path in (azimuth, elevation).

A contact that *begins* between two rows is one event: ``step`` the earlier row, ``t`` the time of
first contact (t_i < t <= t_i+1), ``"between": true``. A contact already present where a stretch of
motion starts is a continuing contact and gives none: rows report their own contacts as before, so
a contact present at both rows is reported at the rows only (each effect's contacts at the rows,
``Rows.contacts``, say where a stretch starts in contact).

Memory and order: a chunk's intervals are handled together (vectorised), in blocks of at most
``SUBSTEP_BLOCK`` sub-steps; the last row of a chunk, its pose and its contacts are carried into the
next chunk (``replay.pipeline``), so an interval straddling a chunk boundary is checked once, by the
later chunk, under the earlier row's step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tankcd_cli.geometry.motion import MAX_TURN_DEG, MESH_TRAVEL, RowIntervals, row_intervals, substep_counts, substeps
from tankcd_cli.matching.match import OFF, Poses, match


def substep_travel(surface) -> float:
    """The largest travel between two sub-steps, m: half the post spacing on a grid, 0.25 m on meshes."""
    spacing = getattr(surface, "spacing", None)
    return float(np.min(spacing)) / 2 if spacing is not None else MESH_TRAVEL


def motion_resolution(surface) -> dict:
    """The sub-steps' resolution, as the summary states it (the effects add theirs:
    ``replay.effects.resolution``)."""
    return {"substep_travel_m": round(substep_travel(surface), 6), "substep_turn_deg": MAX_TURN_DEG}


SUBSTEP_BLOCK = 131072  # sub-steps placed and checked at once (a block of whole intervals)
ROW_FIELDS = ("step", "t", "x", "y", "yaw_deg", "turret_deg", "gun_deg", "entity", "piece_start", "carried")


@dataclass
class Rows:
    """Rows of vehicles of one kind with their poses and the contacts found at them (N of each), each
    vehicle's rows together and in time order (the motion runs between consecutive rows of one
    vehicle, ``entity``, unless the later starts a new piece of motion).

    step, t, x, y, yaw_deg, turret_deg, gun_deg : (N,) the trajectory's columns
    poses : the rows' matched poses (``matching.match.Poses``)
    contacts : each effect's contacts at the rows, by its name ((N, ...) bool: ``Effect.at_rows``);
        where a stretch of motion starts in contact
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
    contacts: dict = field(default_factory=dict)
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
        return Rows(poses=poses, contacts={k: v[idx] for k, v in self.contacts.items()},
                    **{f: getattr(self, f)[idx] for f in ROW_FIELDS})

    @staticmethod
    def join(parts: list) -> "Rows":
        poses = Poses(*(np.concatenate([getattr(r.poses, f) for r in parts]) for f in Poses.__dataclass_fields__))
        contacts = {k: np.concatenate([r.contacts[k] for r in parts]) for k in parts[0].contacts}
        return Rows(poses=poses, contacts=contacts, **{f: np.concatenate([getattr(r, f) for r in parts])
                                                       for f in ROW_FIELDS})

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
class MotionBlock:
    """A block of intervals of ``rows`` (I of them) and the placements along them, what each
    effect's checks along the motion take (``Effect.along``).

    rows : the chunk's rows of one kind (``Rows``, N)
    iv : the block's intervals (``geometry.motion.RowIntervals``, I)
    a, b : (I,) each interval's first and second row in ``rows``
    n : (I,) its rigid sub-steps (segments); n - 1 placements between its rows
    placed : (I,) both its rows have a pose (the ground defines the motion)
    owner, frac : (S,) each placement's interval and fraction of it
    at : each placement's trajectory columns (t, x, y, yaw_deg, turret_deg, gun_deg), (S,)
    sub : the placements' poses (``matching.match.Poses``, S)
    segments : every interval's rigid segments (``_segments``: their ends, where they come from,
        ``use`` where both ends are placed)
    """

    rows: Rows
    iv: RowIntervals
    a: np.ndarray
    b: np.ndarray
    n: np.ndarray
    placed: np.ndarray
    owner: np.ndarray
    frac: np.ndarray
    at: dict
    sub: Poses
    segments: dict


@dataclass
class BetweenResult:
    """What the checks between rows found: the events, per effect and row what the stretch of
    motion ending at the row touched (``Effect.along``'s second value, by effect name), and the
    motion's rigid segments (when asked for)."""

    events: list
    swept_into: dict
    segments: Segments | None = None


@dataclass
class BetweenCounts:
    """What the checks between rows did: intervals and sub-steps placed."""

    intervals: int = 0
    substeps: int = 0


def check_between(rows: Rows, kind, run, counts: BetweenCounts, effects: list,
                  want_segments: bool = False) -> BetweenResult:
    """The events that begin between consecutive rows of ``rows`` (vehicles of one kind: ``kind``
    gives their ``vehicle`` and moving parts, ``body``), for the ``effects`` (``replay.effects.Effect``,
    in their stage order) ``run`` (``replay.pipeline.ReplayRun``) enables for that kind; ``counts``
    is updated."""
    iv = row_intervals(rows.t, rows.x, rows.y, rows.yaw_deg, rows.turret_deg, rows.gun_deg, links=rows.links)
    swept_into: dict = {}
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
    events: list = []
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
                    attitude_tolerance=run.attitude_tolerance, measure=False, regions=run.matcher == "auto",
                    gates=run.gates)
        # each interval's sequence of placements: its first row, its sub-steps, its second row
        first_sub = np.cumsum(n - 1) - (n - 1)
        segments = _segments(rows, ivb, a, b, n, first_sub, sub, placed)
        motion = MotionBlock(rows, ivb, a, b, n, placed, owner, frac, at, sub, segments)
        for effect in effects:
            found, into = effect.along(run, kind, motion)
            events += found
            if into is not None:
                swept_into[effect.name] = swept_into[effect.name] | into if effect.name in swept_into else into
        if want_segments:
            parts.append(_public_segments(rows, ivb, a, segments, piece_first_all[block]))
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
