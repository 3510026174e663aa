"""The trade-off report's sampling-rate stage: a trajectory's motion logged at several rates,
replayed along the motion and at the rows alone, and the contacts the rows alone miss; with the
grouping of a replay's events into contacts that it counts by.

The other stages are in ``tradeoff.stages``, the timing harness in ``tradeoff.timing`` and the peer
libraries in ``tradeoff.peers``; their names are importable from here too, as they were when this
module held them all.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from tankcd_cli.errors import SetupWarning
from tankcd_cli.geometry.motion import motion_at
from tankcd_cli.io.trajectory import TrajectoryChunk
from tankcd_cli.replay.records import ReplayOptions
from tankcd_cli.replay.run import replay_rows
from tankcd_cli.tradeoff.peers import peer_query  # noqa: F401  (re-exported)
from tankcd_cli.tradeoff.stages import (  # noqa: F401  (re-exported)
    FULL,
    LAYOUTS,
    MATCH_VARIANTS,
    QUICK,
    TRIPOD,
    Budget,
    Point,
    Record,
    Results,
    angle_deg,
    collision_poses,
    collision_stage,
    curvature_stage,
    headline_stage,
    internal_stage,
    matching_stage,
    tripod_planes,
)
from tankcd_cli.tradeoff.timing import (  # noqa: F401  (re-exported)
    WIDE_SPREAD,
    Paired,
    cost_text,
    machine,
    paired,
    ratio_text,
    spread_caveat,
    spread_flag,
    timed,
)
from tankcd_cli.replay.effects import ALL_KINDS


# --- the sampling rate: what a check at the rows alone misses ----------------------------

RATES_HZ = (1.0, 2.0, 5.0, 10.0, 50.0)
CONTACT_KINDS = ALL_KINDS  # every kind of event (replay.effects)


@dataclass
class RateRow:
    """One sampling rate: the trajectory's motion logged at ``hz`` (``rows`` rows), replayed along
    the motion (continuous) and at the rows alone (``--discrete``).

    contacts, missed, late : {kind: count} the contacts the continuous check finds, those of them
        the rows-only check misses (no row of the contact has its event there), and those it sees
        only at a row after the contact began between rows
    lag_max : s, the longest of those delays (0 without any)
    continuous, discrete : (median, fastest, slowest) seconds a replay
    ratio, ratio_lo, ratio_hi : continuous / discrete, pair by pair (``Paired``)
    """

    hz: float
    rows: int
    contacts: dict
    missed: dict
    late: dict
    lag_max: float
    continuous: tuple
    discrete: tuple
    ratio: float
    ratio_lo: float
    ratio_hi: float


def _contact_key(e: dict) -> tuple:
    """What a contact is between: the vehicle and the thing met (an obstacle, a drum, the ground; for
    two vehicles both). A vehicle part is not part of it: the gun meeting a wall, then the hull, is
    one contact with the wall."""
    if e["kind"] == "vehicle":
        return e.get("entity"), e["kind"], e["a"], e["b"]
    return e.get("entity"), e["kind"], e["b"]


def contacts(events: list) -> list[dict]:
    """A replay's events (dicts as the events file's lines) grouped into contacts, in the order they
    begin: each {"key", "kind", "t" (first contact), "between" (it began between two rows), "steps"
    (the rows in contact, a sorted list)}.

    A contact with one thing is a run of consecutive rows in contact with it, or it begins between
    two rows (an event with ``"between": true`` under the earlier row's step) and runs on through the
    rows after it that are in contact; it ends at the first row after it not in contact. Rows are
    numbered by ``step`` (consecutive rows of one vehicle, as a single trajectory's are)."""
    by_key: dict = {}
    for e in events:
        by_key.setdefault(_contact_key(e), []).append(e)
    found = []
    for key, evs in by_key.items():
        # a row's event before the contact that begins after it in the same interval
        evs.sort(key=lambda e: (e["step"], bool(e.get("between")), e["t"] if e["t"] is not None else 0.0))
        open_c, last = None, None  # the contact still open, and where it was last seen (step, between)
        for e in evs:
            step, between = int(e["step"]), bool(e.get("between"))
            if between:
                open_c = {"key": key, "kind": e["kind"], "t": e["t"], "between": True, "steps": []}
                found.append(open_c)
            elif open_c is not None and last is not None and (last == (step - 1, False) or last == (step - 1, True)):
                open_c["steps"].append(step)
            elif last == (step, False):
                continue  # the same row again (two parts, or two events of one pair): one row in contact
            else:
                open_c = {"key": key, "kind": e["kind"], "t": e["t"], "between": False, "steps": [step]}
                found.append(open_c)
            last = (step, between)
    found.sort(key=lambda c: (c["t"] if c["t"] is not None else 0.0))
    return found


def missed_contacts(continuous: list, discrete: list) -> tuple[list, list]:
    """Of the contacts of a continuous replay's events, those the rows-only replay's events miss (no
    event of the same pair at any row of the contact), and those it sees late (the contact began
    between rows; the rows-only check's first event is at a later row): (missed, late), each a list
    of (contact, lag s) with lag the delay to the first row that sees it (None when missed)."""
    at_rows = {}
    for e in discrete:
        at_rows.setdefault(_contact_key(e), {})[int(e["step"])] = e["t"]
    missed, late = [], []
    for c in contacts(continuous):
        seen = [at_rows.get(c["key"], {}).get(s) for s in c["steps"]]
        seen = [t for t in seen if t is not None]
        if not seen:
            missed.append((c, None))
        elif c["between"]:
            late.append((c, float(min(seen)) - float(c["t"])))
    return missed, late


def resample(columns: dict, hz: float) -> dict:
    """The motion of a trajectory's rows (``columns``: t, x, y, yaw_deg, turret_deg, gun_deg, (N,)
    each) logged at ``hz``: rows every 1 / hz s from its first row to its last, their states the
    motion's there (``geometry.motion.motion_at``)."""
    t = np.asarray(columns["t"], dtype=float)
    times = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * hz + 1e-9)) + 1) / hz
    return motion_at(t, columns["x"], columns["y"], columns["yaw_deg"], columns["turret_deg"],
                     columns["gun_deg"], times)


def _kinds(items) -> dict:
    counts = dict.fromkeys(CONTACT_KINDS, 0)
    for c in items:
        c = c[0] if isinstance(c, tuple) else c
        counts[c["kind"]] = counts.get(c["kind"], 0) + 1
    return counts


def rate_row(world, columns: dict, hz: float, repeats: int, has_turret: bool | None = None,
             min_seconds: float = 0.0) -> RateRow:
    """One sampling rate (``RateRow``) of the trajectory ``columns`` in ``world`` (``replay.world.World``):
    each mode replayed once for its events (the warm-up), then both timed in pairs. ``has_turret``:
    the trajectory gives turret and gun angles (None: where any of them is not 0), as a CSV with
    those columns does (the gun's checks run only then)."""
    rows = resample(columns, hz)
    if has_turret is None:
        has_turret = bool(np.any(columns["turret_deg"]) or np.any(columns["gun_deg"]))
    n, size = len(rows["t"]), ReplayOptions().chunk_rows
    chunks = []
    for start in range(0, n, size):  # the chunks a reader would give: memory follows one
        step = np.arange(start, min(start + size, n))
        chunks.append(TrajectoryChunk(step, start, *(rows[k][step] for k in ("t", "x", "y", "yaw_deg", "turret_deg",
                                                                              "gun_deg")), has_turret, step.copy()))

    def run(discrete):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SetupWarning)  # said once by a replay of the trajectory itself
            return replay_rows(world, chunks, ReplayOptions(continuous=not discrete))[1]

    cont, disc = run(False), run(True)
    timing = paired(lambda: run(True), lambda: run(False), repeats, warm_up=False, min_seconds=min_seconds)
    missed, late = missed_contacts(cont, disc)
    return RateRow(hz, len(rows["t"]), _kinds(contacts(cont)), _kinds(missed), _kinds(late),
                   max((lag for _, lag in late), default=0.0), timing.b, timing.a, timing.ratio, timing.ratio_lo,
                   timing.ratio_hi)


def rate_stage(res: Results, world, columns: dict, budget: Budget, say, name: str,
               rates=RATES_HZ) -> None:
    """The trajectory's motion logged at each of ``rates`` (Hz), replayed continuous and rows-only:
    the contacts found, those the rows-only check misses per kind, and the cost of each
    (``RateRow``); the truth is the continuous check at the same rate."""
    truth = "the continuous check at the same rate (every contact along the motion between rows)"
    res.axes["rate"] = ("replay", "contacts the rows-only check misses")
    for hz in rates:
        say(f"rate: {name} at {hz:g} Hz, continuous and rows only")
        r = rate_row(world, columns, hz, budget.pair_repeats, columns.get("has_turret"), budget.turn_seconds)
        res.rates.append(r)
        case = f"{name} at {hz:g} Hz ({r.rows:,} rows)"
        for kind in CONTACT_KINDS:
            if r.contacts.get(kind) or r.missed.get(kind):
                res.records.append(Record("rate", case, "continuous", f"contacts_{kind}", r.contacts[kind], "1", truth))
                res.records.append(Record("rate", case, "rows only (--discrete)", f"missed_{kind}", r.missed[kind],
                                          "1", truth))
        res.records.append(Record("rate", case, "rows only (--discrete)", "seen_late", sum(r.late.values()), "1",
                                  truth))
        res.records.append(Record("rate", case, "rows only (--discrete)", "lag_max", r.lag_max, "s", truth))
        res.records.append(Record("rate", case, "continuous", "time_per_replay", r.continuous[0], "s", truth,
                                  *r.continuous[1:]))
        res.records.append(Record("rate", case, "rows only (--discrete)", "time_per_replay", r.discrete[0], "s", truth,
                                  *r.discrete[1:]))
        res.records.append(Record("rate", case, "continuous", "cost_vs_discrete", r.ratio, "1", truth, r.ratio_lo,
                                  r.ratio_hi))
