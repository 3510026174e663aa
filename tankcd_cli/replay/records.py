"""The records a replay is made of and gives back: its options, outputs, events, counts and summary."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from tankcd_cli.gates import GateTally
from tankcd_cli.names import NO_MATCHER, OFF, OK, PLACED_BY, STATUS
from tankcd_cli.replay.effects import EVENT_KINDS, KINDS, Event  # noqa: F401 (the records' kinds and events)


@dataclass(frozen=True)
class ReplayOptions:
    """How a replay runs.

    matcher : one of ``names.MATCHER_CHOICES`` (``auto``: by the region class under the footprint)
    escalate : check key-point poses against the reference's certificate and solve those that fail
        it by the reference (None: for ``auto`` only)
    tolerance : the certificate's height tolerance at the footprint's corners, m (None: derived
        from the vehicle, ``matching.match.escalation_tolerance``)
    attitude_tolerance : the certificate's attitude tolerance, deg (None:
        ``tolerances.ATTITUDE_TOLERANCE_DEG``)
    continuous : check every effect along the motion between rows too (False: the rows only)
    chunk_rows : rows read, matched and written at a time (memory follows it)
    gates : let the conservative gates skip exact work they prove can find nothing (``tankcd_cli.gates``);
        False runs it everywhere, with the same answers (for tests and the trade-off report)
    """

    matcher: str = "auto"
    escalate: bool | None = None
    tolerance: float | None = None
    attitude_tolerance: float | None = None
    continuous: bool = True
    chunk_rows: int = 65536
    gates: bool = True


@dataclass(frozen=True)
class ReplayOutputs:
    """Where a replay writes: the poses CSV (``-`` for stdout, None: not written) and the events
    JSON Lines (None: only counted). Both are written under temporary names and renamed into
    place together when complete."""

    poses: str | None = "-"
    events: str | None = None


@dataclass
class ReplayCounts:
    """What a replay has seen so far: rows, poses per status and per matcher (code counts), events
    at rows and between rows per kind, and the trajectory's extent [x min, y min, x max, y max]."""

    rows: int = 0
    status: np.ndarray = None
    matcher: np.ndarray = None
    vehicle_contacts: int = 0  # contacts between two vehicles
    at_rows: dict = field(default_factory=lambda: dict.fromkeys(EVENT_KINDS, 0))
    between: dict = field(default_factory=lambda: dict.fromkeys(EVENT_KINDS, 0))
    extent: list = field(default_factory=lambda: [np.inf, np.inf, -np.inf, -np.inf])

    def __post_init__(self):
        if self.status is None:
            self.status = np.zeros(len(STATUS), dtype=np.int64)
        if self.matcher is None:
            self.matcher = np.zeros(len(PLACED_BY), dtype=np.int64)

    def add(self, chunk, poses, events) -> None:
        """A chunk's rows, poses and events (``chunk`` None: events alone, the vehicles' last contacts)."""
        for e in events:
            if e.kind == "vehicle":
                self.vehicle_contacts += 1
            else:
                (self.between if e.between else self.at_rows)[e.kind] += 1
        if chunk is None:
            return
        self.rows += len(chunk)
        self.status += np.bincount(poses.status, minlength=len(STATUS))
        placed = poses.status != OFF  # a row without a pose was placed by no matcher
        self.matcher += np.bincount(poses.matcher[placed], minlength=len(PLACED_BY))
        if len(chunk):
            with np.errstate(invalid="ignore"):
                self.extent[0] = min(self.extent[0], float(np.fmin.reduce(chunk.x)))
                self.extent[1] = min(self.extent[1], float(np.fmin.reduce(chunk.y)))
                self.extent[2] = max(self.extent[2], float(np.fmax.reduce(chunk.x)))
                self.extent[3] = max(self.extent[3], float(np.fmax.reduce(chunk.y)))

    def merge(self, other: "ReplayCounts") -> None:
        """Add another replay's counts (a window's, a part's) to these."""
        self.rows += other.rows
        self.status += other.status
        self.matcher += other.matcher
        self.vehicle_contacts += other.vehicle_contacts
        for k in self.at_rows:
            self.at_rows[k] += other.at_rows.get(k, 0)
            self.between[k] += other.between.get(k, 0)
        e, o = self.extent, other.extent
        self.extent = [min(e[0], o[0]), min(e[1], o[1]), max(e[2], o[2]), max(e[3], o[3])]

    @staticmethod
    def of_summary(summary: "ReplaySummary") -> "ReplayCounts":
        """The counts a summary was made of, as far as ``replay.run.summary_of`` reads them (rows,
        events at and between rows, contacts between vehicles, rows per matcher and without a pose;
        not the extent or the partly-off rows, which no summary keeps)."""
        counts = ReplayCounts(rows=summary.rows, vehicle_contacts=summary.vehicle_contacts)
        for k in KINDS:
            counts.at_rows[k] = summary.collisions.get(k, 0)
        counts.at_rows["off_terrain"] = summary.off_terrain
        for k, v in summary.between.items():
            counts.between[k] = v
        for name, v in summary.matchers.items():
            if name == NO_MATCHER:
                counts.status[OFF] = v
            elif name in PLACED_BY:
                counts.matcher[PLACED_BY.index(name)] = v
        return counts

    @property
    def off_terrain_rows(self) -> int:
        """Rows whose pose is not wholly on the terrain (status off or partly off)."""
        return int(self.rows - self.status[OK])


@dataclass
class ReplayTally:
    """What a replay, or a piece of one (a time window, a part of a fleet's trajectory), counted
    and measured: its ``counts``, which ``effects`` ran, each stage's seconds (``seconds_by_effect``)
    and the checks between rows (``motion``: ``intervals`` and ``substeps`` beside the
    resolution's keys; empty for a discrete replay). Pieces merge into the whole's tally, from
    which ``replay.run.summary_of`` builds the one summary."""

    counts: ReplayCounts = field(default_factory=ReplayCounts)
    effects: dict = field(default_factory=dict)
    seconds_by_effect: dict = field(default_factory=dict)
    motion: dict = field(default_factory=dict)
    gates: dict = field(default_factory=dict)  # ``GateTally.as_dict``: what each gate skipped

    def merge(self, other: "ReplayTally") -> None:
        """Add another piece: counts, seconds, intervals and sub-steps summed, an effect that ran in
        either ran, the resolution the first piece's that has one."""
        self.counts.merge(other.counts)
        for k, v in other.effects.items():
            self.effects[k] = self.effects.get(k, False) or v
        for k, v in other.seconds_by_effect.items():
            self.seconds_by_effect[k] = self.seconds_by_effect.get(k, 0.0) + v
        gates = GateTally.of_dict(self.gates)
        gates.merge(GateTally.of_dict(other.gates))
        self.gates = gates.as_dict()
        if not self.motion:
            self.motion = dict(other.motion)
        else:
            for key in ("intervals", "substeps"):
                if key in other.motion:
                    self.motion[key] = self.motion.get(key, 0) + other.motion[key]

    @staticmethod
    def of_summary(summary: "ReplaySummary") -> "ReplayTally":
        """The tally a summary was built of (its counts as ``ReplayCounts.of_summary`` reads them)."""
        return ReplayTally(ReplayCounts.of_summary(summary), dict(summary.effects), dict(summary.seconds_by_effect),
                           dict(summary.motion), dict(summary.gates))


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
        the sub-steps' largest travel and turn, obstacles' pass and time bounds, the gun's step)
    vehicle_contacts : contacts between two vehicles (a trajectory of many entities)
    entities : the trajectory's vehicles (1 without an entity column)
    gates : by gate, the work items it was asked about, those it proved need no exact work, and their
        share (``tankcd_cli.gates.GateTally.as_dict``)
    warnings : every set-up warning the replay raised, one line each (said with ``-q`` too)
    time_origin : the UTC instant of t = 0 (ISO 8601, ``...Z``) when the inputs carry an absolute
        clock, else None
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
    vehicle_contacts: int = 0
    entities: int = 1
    gates: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    time_origin: str | None = None

    @property
    def collided(self) -> bool:
        """Whether any collision was found, at a row, between rows or between vehicles."""
        return bool(sum(self.collisions.values()) or self.vehicle_contacts
                    or sum(self.between.get(k, 0) for k in KINDS))

    @property
    def off_terrain_anywhere(self) -> int:
        """Rows off the terrain, plus stretches of motion that left it between rows."""
        return self.off_terrain + self.between.get("off_terrain", 0)

    def as_dict(self) -> dict:
        return asdict(self)
