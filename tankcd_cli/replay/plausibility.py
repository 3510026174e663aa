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
    """The checks of one vehicle's rows (``name`` labels it in messages: a file, an entity)."""

    def __init__(self, source: str, name: str | None = None, tally=None):
        self.source = source
        self.name = name
        self.tally = tally  # ExerciseChecks: limits how many vehicles one kind of warning names
        self.last = None  # (t, x, y, yaw_deg, line) of the previous row
        self.fast_warned = self.turn_warned = False
        self.moving = 0
        self.off = 0
        self.fits = {k: 0 for k in FITS}
        self.first_off_line = None

    def observe(self, t, x, y, yaw_deg, line) -> None:
        """The next rows (N,) of this vehicle, in order."""
        if len(t) == 0:
            return
        if self.last is not None:
            t, x, y, yaw_deg, line = (np.concatenate([[p], v]) for p, v in zip(self.last, (t, x, y, yaw_deg, line)))
        self.last = (t[-1], x[-1], y[-1], yaw_deg[-1], line[-1])
        if len(t) < 2:
            return
        dt = np.diff(t)
        dist = np.hypot(np.diff(x), np.diff(y))
        with np.errstate(divide="ignore", invalid="ignore"):
            speed = np.where(dt > 0, dist / np.where(dt > 0, dt, 1.0), np.where(dist > 0, np.inf, 0.0))
        who = f"entity {self.name!r}: " if self.name else ""
        if not self.fast_warned:
            fast = np.flatnonzero(speed > MAX_SPEED)
            if len(fast):
                k = fast[0]
                self.fast_warned = True
                hint = ("is t in other units?" if self.name else "are rows of several vehicles interleaved in one "
                        "file (an entity column), or is t in other units?")
                if dt[k] == 0:
                    self._warn(self.source, f"{who}line {line[k + 1]}: {dist[k]:.1f} m from line {line[k]} at the same "
                                            f"t ({t[k]:g} s): no vehicle jumps" + (
                                                "" if self.name else "; are rows of several vehicles interleaved in "
                                                "one file? give each row its vehicle in an entity column"), "speed")
                else:
                    self._warn(self.source, f"{who}line {line[k + 1]}: {speed[k]:.1f} m/s from line {line[k]} "
                                            f"({dist[k]:.1f} m in {dt[k]:g} s), faster than any vehicle "
                                            f"({MAX_SPEED:g} m/s); {hint}", "speed")
        turn = np.abs(shorter_arc_deg(yaw_deg[:-1], yaw_deg[1:]))
        if not self.turn_warned:
            big = np.flatnonzero((turn >= MAX_TURN) & (dt > 0))
            if len(big):
                k = big[0]
                self.turn_warned = True
                self._warn(self.source, f"{who}line {line[k + 1]}: the heading turns {turn[k]:.1f} deg from line "
                                        f"{line[k]} in {dt[k]:g} s; the motion between them takes the shorter way, a "
                                        "guess at that size (rows closer in time would say which way it turned)",
                           "turn")
        moving = np.flatnonzero((speed >= MOVING) & np.isfinite(speed) & (dt > 0))
        if len(moving):
            travel = np.degrees(np.arctan2(np.diff(y)[moving], np.diff(x)[moving]))
            # each row's heading against its own step's direction of travel (the step that follows it)
            yaw = yaw_deg[:-1][moving]
            off = np.abs(shorter_arc_deg(travel, yaw)) > OFF_COURSE
            self.moving += len(moving)
            self.off += int(off.sum())
            if off.any() and self.first_off_line is None:
                self.first_off_line = int(line[:-1][moving][np.argmax(off)])
            for key, fit in FITS.items():
                self.fits[key] += int((np.abs(shorter_arc_deg(travel, fit(yaw))) <= OFF_COURSE / 2).sum())

    def _warn(self, source: str, what: str, kind: str = "motion") -> None:
        from tankcd_cli.errors import warn

        if self.tally is None or self.tally.allow(kind):
            warn(source, what)

    def finish(self) -> None:
        """The heading check, once every row has been seen."""
        if self.moving < 3 or 2 * self.off <= self.moving:
            return
        best = max(self.fits, key=self.fits.get)
        cause = CAUSES[best] if self.fits[best] * 2 > self.moving else (
            "a compass bearing (from north, clockwise: yaw_deg = 90 - bearing), radians, or a sign")
        who = f"entity {self.name!r}: " if self.name else ""
        self._warn(self.source, f"{who}{self.off:,} of {self.moving:,} moving rows head more than {OFF_COURSE:g} deg "
                                f"away from their direction of travel (first at line {self.first_off_line}): the "
                                f"vehicle would drive sideways; likely {cause}", "heading")


class ExerciseChecks:
    """The motion checks of many vehicles' rows, interleaved: one ``MotionChecks`` per entity, each
    kind of warning naming at most ``LIMIT`` vehicles (then how many more it would have named)."""

    LIMIT = 3

    def __init__(self, source: str):
        self.source = source
        self.checks: dict = {}
        self.count: dict = {}

    def allow(self, kind: str) -> bool:
        self.count[kind] = self.count.get(kind, 0) + 1
        return self.count[kind] <= self.LIMIT

    def observe(self, chunk) -> None:
        codes = chunk.entity
        order = np.argsort(codes, kind="stable")
        sorted_codes = codes[order]
        cuts = np.flatnonzero(np.diff(sorted_codes)) + 1
        for rows in np.split(order, cuts):
            if not len(rows):
                continue
            code = int(codes[rows[0]])
            check = self.checks.get(code)
            if check is None:
                check = self.checks[code] = MotionChecks(self.source, chunk.entity_names[code], self)
            check.observe(chunk.t[rows], chunk.x[rows], chunk.y[rows], chunk.yaw_deg[rows], chunk.line[rows])

    def finish(self) -> None:
        from tankcd_cli.errors import warn

        for check in self.checks.values():
            check.finish()
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
