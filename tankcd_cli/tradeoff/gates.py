"""What the conservative gates skip, and what that saves: the scene's trajectory, alone and as a
column of vehicles driving it one after another, replayed with the gates and without them (``--no-gates``), the
two in turn; each gate's share of its work items proven to need no exact work, the time ratio, and
whether the poses and events are the same (they must be: a gate only skips what it proves can find
nothing; docs/formats.md, "Gates")."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from tankcd_cli.tradeoff.timing import paired

COLUMN_VEHICLES = 4
COLUMN_DELAY_S = 1.5  # s between one vehicle of the column and the next on the same route


@dataclass
class GateRow:
    """One replay measured with the gates and without: ``case`` and its ``rows`` and ``vehicles``;
    ``tally`` each gate's {checked, skipped, share_skipped} (the summary's ``gates``); ``on`` and
    ``off`` the seconds of one replay (median, lowest, highest of the turns); ``ratio`` on / off pair
    by pair (median, lowest, highest); ``identical`` the poses and events the same in both."""

    case: str
    rows: int
    vehicles: int
    tally: dict
    on: tuple
    off: tuple
    ratio: float
    ratio_lo: float
    ratio_hi: float
    identical: bool


def write_column(path: str, columns: dict, vehicles: int = COLUMN_VEHICLES, delay: float = COLUMN_DELAY_S) -> int:
    """Write to ``path`` the trajectory ``columns`` (t, x, y, yaw_deg, turret_deg, gun_deg arrays)
    driven by ``vehicles`` vehicles one after another on the same route, each ``delay`` s behind the
    one before: an exercise's CSV with an ``entity`` column (v1, v2, ...), rows in time order.
    Returns its rows."""
    n = len(columns["t"])
    t = np.concatenate([np.asarray(columns["t"], float) + k * delay for k in range(vehicles)])
    rest = [np.tile(np.asarray(columns[key], float), vehicles) for key in ("x", "y", "yaw_deg", "turret_deg",
                                                                           "gun_deg")]
    entity = np.repeat(np.arange(1, vehicles + 1), n)
    order = np.argsort(t, kind="stable")
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg,turret_deg,gun_deg,entity\n")
        for i in order:  # a few thousand rows, once; repr: every bit of each value
            fh.write(",".join(repr(float(v[i])) for v in (t, *rest)) + f",v{entity[i]}\n")
    return len(t)


def _replay(world, path: str, gates: bool):
    """One replay of the trajectory at ``path`` in ``world``: (poses columns, events, the summary's gates)."""
    from tankcd_cli.errors import SetupWarning
    from tankcd_cli.io.poses_csv import pose_columns
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay

    parts, events = [], []

    def keep(chunk, poses, evs):
        if chunk is not None:
            parts.append(pose_columns(chunk.step, chunk.t, poses, chunk.names() if chunk.has_entity else None))
        events.extend(e.as_dict() for e in evs)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SetupWarning)  # said once by a replay of the trajectory itself
        summary = run_replay(world, path, ReplayOutputs(poses=None, events=None), ReplayOptions(gates=gates),
                             observe=keep)
    poses = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]} if parts else {}
    return poses, events, summary


def same_outputs(a: tuple, b: tuple) -> bool:
    """The poses (NaN equal to NaN) and the events of two replays are the same."""
    pa, ea, _ = a
    pb, eb, _ = b
    if pa.keys() != pb.keys() or ea != eb:
        return False
    for k in pa:
        x, y = np.asarray(pa[k]), np.asarray(pb[k])
        if x.shape != y.shape:
            return False
        if x.dtype.kind == "f":
            if not np.array_equal(x, y, equal_nan=True):
                return False
        elif not np.array_equal(x, y):
            return False
    return True


def gate_row(world, path: str, case: str, repeats: int, min_seconds: float = 0.0) -> GateRow:
    """The trajectory at ``path`` replayed in ``world`` with the gates and without: once each for the
    outputs and the tally, then timed in turn (``tradeoff.timing.paired``, ``repeats`` pairs)."""
    on, off = _replay(world, path, True), _replay(world, path, False)
    timing = paired(lambda: _replay(world, path, False), lambda: _replay(world, path, True), repeats,
                    warm_up=False, min_seconds=min_seconds)
    summary = on[2]
    return GateRow(case, summary.rows, max(1, summary.entities), dict(summary.gates), timing.b, timing.a,
                   timing.ratio, timing.ratio_lo, timing.ratio_hi, same_outputs(on, off))


def gates_stage(res, world, trajectory: str, columns: dict, folder: str, budget, say, name: str) -> None:
    """The trajectory at ``trajectory`` alone, and a column of ``COLUMN_VEHICLES`` vehicles driving it
    (written into ``folder``: the checks between vehicles and their gate), each a ``GateRow`` in
    ``res.gates`` and its records; the truth is the same replay with the gates off."""
    import os

    from tankcd_cli.tradeoff.stages import Record

    truth = "the same replay with the gates off (--no-gates): the same poses and events, the exact work everywhere"
    column = os.path.join(folder, "column.csv")
    write_column(column, columns)
    cases = [(name, trajectory),
             (f"{name}, a column of {COLUMN_VEHICLES} vehicles {COLUMN_DELAY_S:g} s apart", column)]
    for case, path in cases:
        say(f"gates: {case}, with and without")
        r = gate_row(world, path, case, budget.pair_repeats, budget.turn_seconds)
        res.gates.append(r)
        label = f"{case} ({r.rows:,} rows)"
        for gate, v in r.tally.items():
            res.records.append(Record("gates", label, gate, "share_skipped", v["share_skipped"], "1", truth))
        res.records.append(Record("gates", label, "gates on", "time_per_replay", r.on[0], "s", truth, *r.on[1:]))
        res.records.append(Record("gates", label, "gates off (--no-gates)", "time_per_replay", r.off[0], "s", truth,
                                  *r.off[1:]))
        res.records.append(Record("gates", label, "gates on", "cost_vs_no_gates", r.ratio, "1", truth, r.ratio_lo,
                                  r.ratio_hi))
        res.records.append(Record("gates", label, "gates on", "outputs_identical", float(r.identical), "1", truth))
