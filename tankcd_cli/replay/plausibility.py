"""Set-up warnings about a trajectory's motion: steps no vehicle makes, headings that contradict it.

Three checks, over the rows of one vehicle as they stream by (``observe`` per chunk, ``finish`` at
the end; each warns once, naming the first row it concerns):

- a step faster than ``MAX_SPEED`` (40 m/s; no tracked vehicle drives half that); a jump at an
  unchanged ``t`` is the same mistake seen another way: rows of several vehicles interleaved in one
  file without an ``entity`` column;
- a heading change of ``MAX_TURN`` (150 deg) or more between two rows: the motion between them
  turns the shorter way, which is a guess at that size;
- headings that contradict the motion: where most rows that move (at least ``MOVING`` m/s) head
  more than ``OFF_COURSE`` (60 deg) away from their direction of travel, the likeliest causes
  are named by the transform that fits best (a compass bearing read as yaw, radians, a sign).
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.geometry.motion import shorter_arc_deg

MAX_SPEED = 40.0  # m/s
MAX_TURN = 150.0  # deg between two rows
MOVING = 1.0  # m/s: slower rows say little about the heading
OFF_COURSE = 60.0  # deg


class MotionChecks:
    """The checks of many vehicles' rows at once, each vehicle by its code (0, 1, ...), vectorized
    over all of them: a chunk's rows are ordered by vehicle (stably), each vehicle's last row of the
    chunk before joins its first, and the checks run on the steps between consecutive rows of the
    same vehicle. ``name`` labels a lone vehicle in messages (a file, an entity); many vehicles are
    named by ``observe_rows``'s ``names``. ``tally`` (ExerciseChecks) limits how many vehicles one
    kind of warning names."""

    def __init__(self, source: str, name: str | None = None, tally=None):
        self.source = source
        self.name = name
        self.tally = tally
        self.names: tuple = (name,)
        self.seen = np.zeros(0, dtype=bool)  # a vehicle's rows have been seen
        self.order: list = []  # vehicle codes in the order first seen (the heading check's order)
        self.last = np.zeros((0, 5))  # (t, x, y, yaw_deg, line) of each vehicle's previous row
        self.fast_warned = np.zeros(0, dtype=bool)
        self.turn_warned = np.zeros(0, dtype=bool)
        self.moving = np.zeros(0, dtype=np.int64)
        self.off = np.zeros(0, dtype=np.int64)
        self.fits = np.zeros((len(FITS), 0), dtype=np.int64)
        self.first_off_line = np.zeros(0, dtype=np.int64)  # -1: none yet
        self.where = "line"  # what a row's line counts: "line", or "packet" for a capture

    def observe(self, t, x, y, yaw_deg, line) -> None:
        """The next rows (N,) of the lone vehicle, in order."""
        self.observe_rows(np.zeros(len(t), dtype=np.int64), t, x, y, yaw_deg, line, (self.name,))

    def observe_rows(self, codes, t, x, y, yaw_deg, line, names) -> None:
        """The next rows (N,) of many vehicles, ``codes`` (N,) naming each row's vehicle (``names``
        indexed by code), each vehicle's rows in order."""
        if len(t) == 0:
            return
        self.names = tuple(names)
        self._grow(max(int(codes.max()) + 1, len(self.names)))
        present = np.unique(codes)
        self.order += [int(c) for c in present[~self.seen[present]]]
        carried = present[self.seen[present]]
        # each vehicle's rows in order, its previous row first: position -1 sorts before the chunk's rows
        code = np.concatenate([carried, codes])
        pos = np.concatenate([np.full(len(carried), -1), np.arange(len(codes))])
        cols = [np.concatenate([self.last[carried, i], np.asarray(v, dtype=float)])
                for i, v in enumerate((t, x, y, yaw_deg, line))]
        k = np.lexsort((pos, code))
        code = code[k]
        t, x, y, yaw_deg, line = (c[k] for c in cols)
        line = line.astype(np.int64)
        self.seen[present] = True
        final = np.flatnonzero(np.r_[code[1:] != code[:-1], True])
        self.last[code[final]] = np.column_stack([t, x, y, yaw_deg, line])[final]
        step = np.flatnonzero(code[1:] == code[:-1])  # steps between two rows of one vehicle: row k to k + 1
        if len(step) == 0:
            return
        who = code[step]
        dt = t[step + 1] - t[step]
        dx, dy = x[step + 1] - x[step], y[step + 1] - y[step]
        dist = np.hypot(dx, dy)
        with np.errstate(divide="ignore", invalid="ignore"):
            speed = np.where(dt > 0, dist / np.where(dt > 0, dt, 1.0), np.where(dist > 0, np.inf, 0.0))
        turn = np.abs(shorter_arc_deg(yaw_deg[step], yaw_deg[step + 1]))
        messages = []  # (vehicle, check, message, kind): said by vehicle, then check, as a vehicle's rows read
        for j in _first_per_vehicle(who, (speed > MAX_SPEED) & ~self.fast_warned[who]):
            self.fast_warned[who[j]] = True
            messages.append((who[j], 0, self._fast(who[j], line[step[j]], line[step[j] + 1], t[step[j]], dist[j],
                                                   dt[j], speed[j]), "speed"))
        for j in _first_per_vehicle(who, (turn >= MAX_TURN) & (dt > 0) & ~self.turn_warned[who]):
            self.turn_warned[who[j]] = True
            w = self.where
            messages.append((who[j], 1, f"{self._who(who[j])}{w} {line[step[j] + 1]}: the heading turns "
                                        f"{turn[j]:.1f} deg from {w} {line[step[j]]} in {dt[j]:g} s; the motion "
                                        "between them takes the shorter way, a guess at that size (rows closer in "
                                        "time would say which way it turned)", "turn"))
        for _, _, what, kind in sorted(messages, key=lambda m: (m[0], m[1])):
            self._warn(self.source, what, kind)
        moving = np.flatnonzero((speed >= MOVING) & np.isfinite(speed) & (dt > 0))
        if len(moving):
            mover = who[moving]
            travel = np.degrees(np.arctan2(dy[moving], dx[moving]))
            # each row's heading against its own step's direction of travel (the step that follows it)
            yaw = yaw_deg[step[moving]]
            off = np.abs(shorter_arc_deg(travel, yaw)) > OFF_COURSE
            size = len(self.moving)
            self.moving += np.bincount(mover, minlength=size)
            self.off += np.bincount(mover[off], minlength=size)
            for j in _first_per_vehicle(mover, off & (self.first_off_line[mover] < 0)):
                self.first_off_line[mover[j]] = line[step[moving[j]]]
            for i, fit in enumerate(FITS.values()):
                good = np.abs(shorter_arc_deg(travel, fit(yaw))) <= OFF_COURSE / 2
                self.fits[i] += np.bincount(mover[good], minlength=size)

    def _grow(self, size: int) -> None:
        more = size - len(self.seen)
        if more <= 0:
            return
        self.seen = np.r_[self.seen, np.zeros(more, dtype=bool)]
        self.last = np.vstack([self.last, np.zeros((more, 5))])
        self.fast_warned = np.r_[self.fast_warned, np.zeros(more, dtype=bool)]
        self.turn_warned = np.r_[self.turn_warned, np.zeros(more, dtype=bool)]
        self.moving = np.r_[self.moving, np.zeros(more, dtype=np.int64)]
        self.off = np.r_[self.off, np.zeros(more, dtype=np.int64)]
        self.fits = np.hstack([self.fits, np.zeros((len(FITS), more), dtype=np.int64)])
        self.first_off_line = np.r_[self.first_off_line, np.full(more, -1, dtype=np.int64)]

    def _who(self, code) -> str:
        name = self.names[code] if code < len(self.names) else None
        return f"entity {name!r}: " if name else ""

    def _fast(self, code, line0, line1, t0, dist, dt, speed) -> str:
        who, w = self._who(code), self.where
        named = bool(who)
        if dt == 0:
            return (f"{who}{w} {line1}: {dist:.1f} m from {w} {line0} at the same t ({t0:g} s): no vehicle jumps"
                    + ("" if named else "; are rows of several vehicles interleaved in one file? give each row its "
                       "vehicle in an entity column"))
        hint = ("is t in other units?" if named else "are rows of several vehicles interleaved in one file (an "
                "entity column), or is t in other units?")
        return (f"{who}{w} {line1}: {speed:.1f} m/s from {w} {line0} ({dist:.1f} m in {dt:g} s), faster than any "
                f"vehicle ({MAX_SPEED:g} m/s); {hint}")

    def _warn(self, source: str, what: str, kind: str = "motion") -> None:
        from tankcd_cli.errors import warn

        if self.tally is None or self.tally.allow(kind):
            warn(source, what)

    def finish(self) -> None:
        """The heading check, once every row has been seen (each vehicle in the order first seen)."""
        keys = list(FITS)
        for code in self.order:
            moving, off = int(self.moving[code]), int(self.off[code])
            if moving < 3 or 2 * off <= moving:
                continue
            fits = self.fits[:, code]
            best = int(np.argmax(fits))  # the first of equal fits, in FITS' order
            cause = CAUSES[keys[best]] if fits[best] * 2 > moving else (
                "a compass bearing (from north, clockwise: yaw_deg = 90 - bearing), radians, or a sign")
            self._warn(self.source, f"{self._who(code)}{off:,} of {moving:,} moving rows head more than "
                                    f"{OFF_COURSE:g} deg away from their direction of travel (first at {self.where} "
                                    f"{self.first_off_line[code]}): the vehicle would drive sideways; likely {cause}",
                       "heading")


def _first_per_vehicle(who: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Indices of the first True of ``mask`` for each vehicle (``who`` sorted), in vehicle order."""
    hit = np.flatnonzero(mask)
    if len(hit) == 0:
        return hit
    return hit[np.r_[True, who[hit][1:] != who[hit][:-1]]]


class ExerciseChecks:
    """The motion checks of many vehicles' rows, interleaved (``MotionChecks`` over every entity),
    each kind of warning naming at most ``LIMIT`` vehicles (then how many more it would have named)."""

    LIMIT = 3

    def __init__(self, source: str):
        self.source = source
        self.checks = MotionChecks(source, tally=self)
        self.count: dict = {}

    def allow(self, kind: str) -> bool:
        self.count[kind] = self.count.get(kind, 0) + 1
        return self.count[kind] <= self.LIMIT

    def observe(self, chunk) -> None:
        self.checks.where = chunk.where
        self.checks.observe_rows(chunk.entity, chunk.t, chunk.x, chunk.y, chunk.yaw_deg, chunk.line,
                                 chunk.entity_names)

    def finish(self) -> None:
        from tankcd_cli.errors import warn

        self.checks.finish()
        for kind, n in self.count.items():
            if n > self.LIMIT:
                warn(self.source, f"and {n - self.LIMIT:,} more vehicles with the same {kind} warning")


FITS = {
    "compass": lambda yaw: 90.0 - yaw,
    "radians": lambda yaw: np.degrees(yaw),
    "negated": lambda yaw: -yaw,
    "reversed": lambda yaw: yaw + 180.0,
}
CAUSES = {
    "compass": "a compass bearing read as yaw (yaw_deg is counter-clockwise from east: yaw_deg = 90 - bearing)",
    "radians": "headings in radians (yaw_deg is in degrees)",
    "negated": "the heading's sign (yaw_deg turns counter-clockwise, from east)",
    "reversed": "headings 180 deg off (the vehicle reversing the whole way, or the heading of its rear)",
}
