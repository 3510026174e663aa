"""An exercise replayed by time windows, each window a task run by ``replay.executor``: in this
process, in forked processes (``--jobs``), or on a Dask cluster for an exercise too big for one
machine. The poses and events written are those of a local run
(``replay.run.run_replay``) byte for byte, because every window decides what is its own by the
local run's own rules:

- **The grid.** The local run searches vehicle contacts in windows of ``replay.effects.vehicles.WINDOW``
  seconds from the first chunk's earliest time (``VehicleContacts``); a task's window is a whole
  number of them, on the same grid (the same floats: each edge the one before plus the width), so
  every contact window is checked with the same segments cut at the same instants.
- **Rows.** A task places its own rows (``t`` in its window; rows before the grid belong to the
  first, rows after the last edge to the last) and, per entity, the last two rows before its start
  (the interval crossing the start edge, and the one before it, whose end says whether an obstacle
  contact continues into the window) and the first row after its end (the interval crossing the end
  edge). It keeps the poses of its own rows only, and the events of its own rows and of the
  intervals that end at them (the local run checks an interval with the chunk of its later row).
- **Vehicle contacts.** A task runs the contact windows of its span, each with the segments the
  local run had buffered when it closed that window: those of intervals whose later row was read
  by then (which chunk the local run had read when each window closed is found by one pass over
  the trajectory's times that plays the local run's watermark), in the buffer's order. A contact
  belongs to the window holding its first-contact time; one already going on at a window's start
  continues the earlier window's (``VehicleContacts``'s own rule), so none is reported twice.
- **Order.** Every event carries the place the local run writes it at (the chunk, then the step
  and time, or the contact window), and the results are joined in that order; the poses by step.
  A task gives back arrays and event records; the joining writes them through the run in one
  piece's writers (``replay.outputs``), so every output format is written by windows too.

Memory: a task holds its window's rows and segments; the joining holds the results not yet
written (the windows finished ahead of the next in order, and rows of a window that interleave
with the next one's in the file).

The trajectory is read once by the planning pass (times and entities: the watermark and each
window's rows), and each task reads the parts of the file (CSV lines, ``io.trajectory``) that hold
its rows; an input that is no CSV (GPX, a capture) is decoded and converted once by the planning
pass when the tasks run here (``_Spool``: arrays each task reads by range), else read whole by
every task (a cluster's workers do not see this machine's temporary folder).

Rows out of time order across vehicles (grouped by vehicle, one silent past the horizon: the
planning pass plays the order check) close every contact window after the last chunk, as a run in
one piece that keeps every segment does: each task then runs its windows with every segment they
need, and the events are those of the same rows in time order.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import shutil
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Callable

import numpy as np

from tankcd_cli.errors import SetupWarning, collected_warnings, warn
from tankcd_cli.gates import GateTally
from tankcd_cli.io.trajectory import TrajectoryChunk, TrajectoryReader, split_trajectory, trajectory_format, utc_text
from tankcd_cli.matching.match import Poses
from tankcd_cli.replay.effects import vehicles
from tankcd_cli.replay.between_rows import Segments
from tankcd_cli.replay.effects import resolution
from tankcd_cli.replay.executor import Executor, TaskWorld, dask_client, keep_loaded, load_world_once, worker_threads
from tankcd_cli.replay.outputs import replay_metadata, replay_outputs
from tankcd_cli.replay.pipeline import replay_chunks, start_run
from tankcd_cli.replay.plausibility import ExerciseChecks, MotionChecks
from tankcd_cli.replay.records import ReplayCounts, ReplayOptions, ReplayOutputs, ReplaySummary, ReplayTally
from tankcd_cli.replay.run import summary_of, warn_if_beside

DEFAULT_WINDOW_SECONDS = 60.0
SPARSE_WINDOWS = 100_000  # contact windows a plan may hold beyond SPARSE_WINDOWS_PER_ROW a row
SPARSE_WINDOWS_PER_ROW = 64  # a vehicle's rows a minute apart: 30 windows a row


class SparseTime(Exception):
    """An exercise whose time span holds far more contact windows than rows (a clock jump, a row a
    year later): its plan would cost by time, not rows (a task, a join slot and a window's
    bookkeeping for every 2 s of empty time), so it is not cut into windows; the caller replays it
    in one piece, which skips empty time (``replay.effects.vehicles``), with the same poses and events."""

    def __init__(self, windows: float, rows: int, width: float):
        self.windows, self.rows = windows, rows
        super().__init__(f"{windows * width:.6g} s of time for {rows:,} rows, {windows:.3g} contact windows of "
                         f"{width:g} s: far more windows than rows (a clock jump?)")



@dataclass(frozen=True)
class ContactWindow:
    """One window of the vehicle-contact search: [w0, w1), the local run's chunk after which it
    closes (``emit``; the number of chunks: at the end) and whether it is the last."""

    index: int
    w0: float
    w1: float
    emit: int
    last: bool


@dataclass(frozen=True)
class WindowTask:
    """One time window of an exercise, as a task: what to read and what is its own.

    index : the window's place in time (0 first)
    trajectory : the input's path; fmt : its format (None: by suffix)
    parts : the CSV parts (``io.trajectory.TrajectoryPart``) holding its rows, in order (None: read
        the whole input, stopping after ``last_step``)
    t0, t1 : its own rows are those with t0 <= t < t1 (-inf and inf at the ends)
    lead : (n,) steps of the rows before it that seed motion into it; trailing : (m,) steps of each
        entity's first row after it
    windows : the contact windows it runs (``ContactWindow``), in order
    kept_until : the chunk after which the contact window before its first closed (-1: none)
    names : every entity name, by code (the whole input's codes); first_step : each entity's first
        row's step, by code; chunk_starts : each local chunk's first step
    has_turret, has_entity : the input's (as its first chunk says)
    chunk_rows : the local run's chunk; last_step : its last row's step (own or trailing)
    spool : (folder, where, first, last) for an input that is no CSV converted once by the planning
        pass (``_Spool``): its rows are read from the folder's arrays, its own between steps first
        and last (None: the input is read by ``parts``, or whole)
    """

    index: int
    trajectory: str
    fmt: str | None
    parts: tuple | None
    t0: float
    t1: float
    lead: np.ndarray
    trailing: np.ndarray
    windows: tuple
    kept_until: int
    names: tuple
    first_step: np.ndarray
    chunk_starts: np.ndarray
    has_turret: bool
    has_entity: bool
    chunk_rows: int
    last_step: int
    spool: tuple | None = None


@dataclass
class PoseRows:
    """Pose rows as arrays: their times ``t`` (N,), entity codes ``entity``
    (N,) (the whole input's codes; None without entities) and ``poses`` (``matching.match.Poses``,
    every field's first axis N)."""

    t: np.ndarray
    entity: np.ndarray | None
    poses: object

    @staticmethod
    def of(parts: list) -> "PoseRows":
        """The tables of ``parts`` one after the other."""
        return PoseRows(np.concatenate([p.t for p in parts]),
                         None if parts[0].entity is None else np.concatenate([p.entity for p in parts]),
                         Poses(**{f: np.concatenate([getattr(p.poses, f) for p in parts])
                                  for f in Poses.__dataclass_fields__}))

    def __len__(self) -> int:
        return len(self.t)

    def index(self, idx) -> "PoseRows":
        """Rows ``idx`` (a slice or an index array)."""
        return PoseRows(self.t[idx], None if self.entity is None else self.entity[idx],
                         Poses(**{f: getattr(self.poses, f)[idx] for f in Poses.__dataclass_fields__}))

    def take(self, lo: int, hi: int) -> "PoseRows":
        """Rows lo .. hi - 1."""
        return self.index(slice(lo, hi))

    @staticmethod
    def merged(parts: list, order: np.ndarray) -> "PoseRows":
        """The rows of ``parts`` (taken as one table in turn) in ``order``."""
        return PoseRows.of(parts).index(order)


@dataclass
class WindowResult:
    """What one window's task gives back: its own rows' steps and pose rows (``PoseRows``; None
    without rows), its events (``Event`` records, each with its place in the local run's order:
    ``event_keys``), its tally (counts, effects, seconds, and intervals and sub-steps of its own
    intervals with the resolution between rows: what the summary is built of), the terrain's
    extent and CRS; the worker's pid and the task's seconds."""

    index: int
    steps: np.ndarray
    pose_rows: object
    event_keys: list
    event_lines: list
    tally: ReplayTally
    bounds: tuple = ()
    crs: str = ""
    pid: int = 0
    task_seconds: float = 0.0
    warnings: list = field(default_factory=list)


@dataclass
class WindowPlan:
    """An exercise cut into window tasks (``plan_windows``): the tasks in time order, per task the
    least step of its own rows and the least local chunk its events are written with (what says
    when the results before it are complete), and the input's rows and chunks."""

    tasks: list
    min_step: np.ndarray
    min_chunk: np.ndarray
    rows: int
    chunks: int
    has_entity: bool
    entities: int
    geographic: bool
    warnings: list = field(default_factory=list)  # the planning pass's set-up warnings (the motion checks)
    spool: str | None = None  # the folder of the rows converted once (``_Spool``), removed by ``close``
    time_origin: float | None = None  # the UTC instant of t = 0, epoch seconds (None: relative times)

    def close(self) -> None:
        """Remove the rows converted for the tasks (once they have run)."""
        if self.spool is not None:
            shutil.rmtree(self.spool, ignore_errors=True)
            self.spool = None


# --- planning -----------------------------------------------------------------------------------

class _Grid:
    """The contact windows' edges, as the local run makes them (each the one before plus the width),
    grown on demand."""

    def __init__(self, origin: float, width: float):
        self.width = width
        self.edges = [origin]

    def cover(self, t: float) -> None:
        while self.edges[-1] <= t:
            self.edges.append(self.edges[-1] + self.width)


def plan_windows(trajectory: str, options: ReplayOptions = ReplayOptions(), window_seconds: float = 60.0,
                 fmt: str | None = None, crs: str | None = None, spool_dir: str | None = None) -> WindowPlan:
    """One pass over ``trajectory`` (times and entities, the local run's chunks) into window tasks of
    ``window_seconds`` (rounded to a whole number of contact windows, at least one). Bad rows are
    the local run's errors (``InputError``), raised here before any task runs; the motion checks'
    set-up warnings are said here and kept in the plan's ``warnings``.

    crs : the terrain's CRS (``World.crs``), given when the tasks run on this machine: an input that
        is no CSV (a capture, GPX) is then decoded and converted to it once, here, into arrays in a
        temporary folder (under ``spool_dir``; the system's by default) that each task reads by
        its rows' range, where without it every task decodes the whole input again. ``run_windows``
        removes the folder (``WindowPlan.close``)."""
    with collected_warnings() as said:
        plan = _plan(trajectory, options, window_seconds, fmt, crs, spool_dir)
    plan.warnings = list(said)
    return plan


class _Spool:
    """The rows of an input that is no CSV as the reader gives them, converted to the terrain's CRS,
    written once by the planning pass: one raw array file per field in a temporary folder, appended
    chunk by chunk (memory: one chunk), read back by the tasks as memory maps (``_spooled``)."""

    FIELDS = (("step", np.int64), ("t", np.float64), ("x", np.float64), ("y", np.float64),
              ("yaw_deg", np.float64), ("turret_deg", np.float64), ("gun_deg", np.float64), ("line", np.int64),
              ("piece_start", np.bool_), ("entity", np.int64))

    def __init__(self, folder: str | None):
        self.folder = tempfile.mkdtemp(prefix="tankcd-windows-", dir=folder)
        self.files = {f: open(os.path.join(self.folder, f), "wb") for f, _ in self.FIELDS}
        self.rows = 0

    def add(self, chunk) -> None:
        n = len(chunk)
        if n and int(chunk.step[0]) != self.rows:  # a row's step is its place here: what the tasks index by
            raise RuntimeError(f"spooled rows out of step: {int(chunk.step[0])} after {self.rows} rows")
        for f, dtype in self.FIELDS:
            value = getattr(chunk, f)
            if value is None:
                value = np.zeros(n, dtype)
            self.files[f].write(np.ascontiguousarray(value, dtype).tobytes())
        self.rows += n

    def close(self) -> None:
        for fh in self.files.values():
            fh.close()

    def remove(self) -> None:
        self.close()
        shutil.rmtree(self.folder, ignore_errors=True)


def _spooled(folder: str, steps: np.ndarray) -> dict:
    """The spooled rows at ``steps`` (sorted, unique: a row's step is its place in the input)."""
    out = {}
    for f, dtype in _Spool.FIELDS:
        path = os.path.join(folder, f)
        if os.path.getsize(path) == 0 or not len(steps):
            out[f] = np.zeros(0, dtype)
            continue
        out[f] = np.array(np.memmap(path, dtype=dtype, mode="r")[steps])
    return out


def _plan(trajectory, options, window_seconds, fmt, crs=None, spool_dir=None) -> WindowPlan:
    is_csv = trajectory_format(trajectory, fmt) == "csv"
    spooled = not is_csv and crs is not None and trajectory != "-"
    reader = TrajectoryReader(trajectory, options.chunk_rows, crs=crs, fmt=fmt, convert=spooled)
    spool = _Spool(spool_dir) if spooled else None
    try:
        plan = _planned(trajectory, options, window_seconds, fmt, reader, is_csv, spool)
    except BaseException:
        if spool is not None:
            spool.remove()
        raise
    if spool is not None:
        spool.close()
        plan.spool = spool.folder
    return plan


def _planned(trajectory, options, window_seconds, fmt, reader, is_csv, spool) -> WindowPlan:
    from tankcd_cli.io.trajectory import split_trajectory
    from tankcd_cli.replay.effects import vehicles
    from tankcd_cli.replay.plausibility import ExerciseChecks, MotionChecks

    width = vehicles.WINDOW
    per_task = max(1, int(round(window_seconds / width)))
    watch = vehicles.VehicleContacts(None, continuous=options.continuous)
    parts = split_trajectory(trajectory, options.chunk_rows) if is_csv and trajectory != "-" else None
    part_steps = np.array([p.step_offset for p in parts], dtype=np.int64) if parts else None
    grid = None
    checks = None
    emits: list = []  # the chunk after which each contact window closed
    chunk_starts: list = []
    first_step = np.zeros(0, np.int64)
    last = np.full((0, 2), -1, np.int64)  # each entity's last two rows' steps (older, newer)
    last_t = np.zeros(0)
    crossings = []  # arrays of (lo task, hi task, the row after, the row before, the one before that)
    own_min: dict = {}
    own_max: dict = {}
    own_parts: dict = {}
    rows = 0
    t_end = -np.inf
    has_turret = has_entity = False
    ordered = True  # the rows in time order across vehicles, as the streaming checks between them need
    order = vehicles.OrderCheck()  # the one-piece run's own test of it
    names: tuple = ()
    time_origin = None
    for c, chunk in enumerate(reader):
        if grid is None:
            grid = _Grid(float(np.floor(chunk.t.min() / width) * width), width)
            has_turret, has_entity = chunk.has_turret, chunk.has_entity
            time_origin = chunk.time_origin
            if not reader.geographic or spool is not None:  # positions known (converted, for the spool)
                checks = ExerciseChecks(trajectory) if has_entity else MotionChecks(trajectory)
        if spool is not None:
            spool.add(chunk)
        if checks is not None:
            if has_entity:
                checks.observe(chunk)
            else:
                checks.observe(chunk.t, chunk.x, chunk.y, chunk.yaw_deg, chunk.line)
        chunk_starts.append(int(chunk.step[0]))
        windows = (max(t_end, float(chunk.t.max())) - grid.edges[0]) / width
        if windows > SPARSE_WINDOWS + SPARSE_WINDOWS_PER_ROW * (rows + len(chunk)):
            raise SparseTime(windows, rows + len(chunk), width)
        before = watch.done_until if watch.done_until is not None else grid.edges[0]
        watch.ready(chunk)
        w = before
        while w < watch.done_until:
            emits.append(c)
            w = w + width
        rows += len(chunk)
        t_end = max(t_end, float(chunk.t.max()))
        grid.cover(t_end)
        names = chunk.entity_names
        codes = chunk.entity if chunk.entity is not None else np.zeros(len(chunk), np.int64)
        if len(names) > len(first_step):
            grow = len(names) - len(first_step)
            first_step = np.r_[first_step, np.full(grow, -1, np.int64)]
            last = np.r_[last, np.full((grow, 2), -1, np.int64)]
            last_t = np.r_[last_t, np.full(grow, -np.inf)]
        if ordered and has_entity:
            ordered = order.observe(chunk)
        starts = np.asarray(grid.edges[::per_task])
        task = np.maximum(np.searchsorted(starts, chunk.t, side="right") - 1, 0)
        _own(task, chunk.step, part_steps, own_min, own_max, own_parts)
        _crossings(codes, chunk.step, chunk.t, task, starts, first_step, last, last_t, crossings)
    reader.close()
    if checks is not None:
        checks.finish()
    if grid is None:
        return WindowPlan([], np.zeros(0, np.int64), np.zeros(0, np.int64), 0, 0, False, 0, False)
    edges = grid.edges
    n_windows = int(np.searchsorted(edges, t_end, side="right"))  # windows starting at or before the end
    n_chunks = len(chunk_starts)
    emits += [n_chunks] * (n_windows - len(emits))
    if not ordered:
        # rows out of time order across vehicles (grouped by vehicle, one silent past the horizon):
        # a run in one piece keeps every segment and checks the windows at the end, with all of them;
        # so does every task here (each holds every segment its windows need), whatever the order
        emits = [n_chunks] * n_windows
    n_tasks = (n_windows - 1) // per_task + 1
    lead, trailing = _extra_rows(crossings, n_tasks)
    tasks = []
    min_step = np.zeros(n_tasks, np.int64)
    min_chunk = np.zeros(n_tasks, np.int64)
    starts_arr = np.asarray(chunk_starts, np.int64)
    for j in range(n_tasks):
        ks = range(j * per_task, min((j + 1) * per_task, n_windows))
        windows = tuple(ContactWindow(k, edges[k], edges[k + 1], emits[k], edges[k + 1] > t_end) for k in ks)
        extra_lead = lead.get(j, np.zeros(0, np.int64))
        extra_trailing = trailing.get(j, np.zeros(0, np.int64))
        needed = set(own_parts.get(j, ()))
        if part_steps is not None:
            for s in np.r_[extra_lead, extra_trailing]:
                needed.add(int(np.searchsorted(part_steps, s, side="right") - 1))
        last_step = max([own_max.get(j, -1)] + [int(s) for s in extra_trailing[-1:]])
        tasks.append(WindowTask(
            j, trajectory, fmt, tuple(parts[p] for p in sorted(needed)) if parts is not None else None,
            edges[j * per_task] if j > 0 else -np.inf, edges[(j + 1) * per_task] if j < n_tasks - 1 else np.inf,
            extra_lead, extra_trailing, windows, emits[j * per_task - 1] if j > 0 else -1, names, first_step,
            starts_arr, has_turret, has_entity, options.chunk_rows, last_step,
            spool=(spool.folder, reader.where, own_min.get(j, 0), own_max.get(j, -1)) if spool is not None else None))
        min_step[j] = own_min.get(j, np.iinfo(np.int64).max)
        first_chunk = int(np.searchsorted(starts_arr, min_step[j], side="right") - 1) if j in own_min else n_chunks
        min_chunk[j] = min([first_chunk] + [w.emit for w in windows])
    return WindowPlan(tasks, min_step, min_chunk, rows, n_chunks, has_entity, len(names), bool(reader.geographic),
                      time_origin=time_origin)


def _own(task, steps, part_steps, own_min, own_max, own_parts) -> None:
    """Each task's own rows in a chunk: their least and greatest steps and the parts holding them."""
    order = np.argsort(task, kind="stable")
    ts = task[order]
    cuts = np.flatnonzero(np.diff(ts)) + 1
    for group in np.split(order, cuts):
        j = int(task[group[0]])
        lo, hi = int(steps[group].min()), int(steps[group].max())
        own_min[j] = min(own_min.get(j, lo), lo)
        own_max[j] = max(own_max.get(j, hi), hi)
        if part_steps is not None:
            found = np.unique(np.searchsorted(part_steps, steps[group], side="right") - 1)
            own_parts.setdefault(j, set()).update(int(p) for p in found)


def _crossings(codes, steps, t, task, starts, first_step, last, last_t, out) -> None:
    """The intervals of a chunk that cross a task's edge (the row before in another task than the row
    after), with the row before that: what the tasks between them read besides their own rows.
    ``first_step``, ``last`` (each entity's last two steps) and ``last_t`` carry across chunks."""
    order = np.argsort(codes, kind="stable")
    e, s, ts, task = codes[order], steps[order], t[order], task[order]
    n = len(e)
    head = np.r_[True, e[1:] != e[:-1]]
    tail = np.r_[head[1:], True]
    begin = np.maximum.accumulate(np.where(head, np.arange(n), 0))
    pos = np.arange(n) - begin  # the row's place among its entity's rows in the chunk
    new = head & (first_step[e] < 0)
    first_step[e[new]] = s[new]
    prev = np.where(pos == 0, last[e, 1], np.r_[-1, s[:-1]])
    prev2 = np.where(pos == 0, last[e, 0], np.where(pos == 1, last[e, 1], np.r_[-1, -1, s[:-2]][:n]))
    prev_t = np.where(pos == 0, last_t[e], np.r_[-np.inf, ts[:-1]])
    prev_task = np.maximum(np.searchsorted(starts, prev_t, side="right") - 1, 0)
    cross = (prev >= 0) & (prev_task < task)
    if cross.any():
        out.append(np.column_stack([prev_task[cross], task[cross], s[cross], prev[cross], prev2[cross]]))
    last[e[tail], 0] = prev[tail]
    last[e[tail], 1] = s[tail]
    last_t[e[tail]] = ts[tail]


def _extra_rows(crossings, n_tasks):
    """Per task, the steps of the rows before its start (lead) and after its end (trailing)."""
    if not crossings:
        return {}, {}
    lo, hi, after, before, before2 = np.concatenate(crossings).T

    def spread(first, stop, values):  # (task, step) for every task first..stop-1 of each crossing
        count = np.maximum(stop - first, 0)
        tasks = np.repeat(first - np.cumsum(count) + count, count) + np.arange(count.sum())
        steps = np.repeat(values, count)
        keep = steps >= 0
        return tasks[keep], steps[keep]

    hi_lead = np.minimum(hi, n_tasks - 1) + 1
    j1, s1 = spread(lo + 1, hi_lead, before)
    j2, s2 = spread(lo + 1, hi_lead, before2)
    j3, s3 = spread(lo, np.minimum(hi, n_tasks), after)
    return _by_task(np.r_[j1, j2], np.r_[s1, s2]), _by_task(j3, s3)


def _by_task(tasks, steps) -> dict:
    order = np.lexsort((steps, tasks))
    tasks, steps = tasks[order], steps[order]
    cuts = np.flatnonzero(np.diff(tasks)) + 1
    return {int(g[0]): np.unique(v) for g, v in zip(np.split(tasks, cuts), np.split(steps, cuts)) if len(g)}


# --- one window ---------------------------------------------------------------------------------

class _Segments:
    """Stands in for a run's vehicle checks while a window's rows are replayed: keeps every segment
    (to be run window by window afterwards) and closes no window itself."""

    def __init__(self):
        self.parts = []  # (kind index, Segments)

    def add(self, kind, segments) -> None:
        if segments is not None and len(segments):
            self.parts.append((kind.index, segments))

    def add_rows(self, kind, chunk, poses) -> None:
        pass

    def ready(self, chunk) -> list:
        return []

    def finish(self) -> list:
        return []

    def close(self) -> None:
        pass


def run_window(world: TaskWorld, task: WindowTask, kernel_threads: int | None = None) -> WindowResult:
    """One window's task on a worker: the world (``replay.executor.TaskWorld``) loaded once per
    process, then ``replay_window``."""
    if kernel_threads is not None:
        worker_threads(kernel_threads)
    return replay_window(load_world_once(world.spec), world.options, task)


def replay_window(world, options: ReplayOptions, task: WindowTask) -> WindowResult:
    """Replay one window of an exercise in a loaded ``world``: its own rows' poses and events, and
    the vehicle contacts of its contact windows, each event with its place in the local run's order.
    Its set-up warnings are recorded in the result, not shown (the task may run in another process
    or on a cluster: the joining says each once); under an ``error`` filter (``--strict``) one is
    raised as ever."""
    with _recorded_warnings() as said:
        result = _replay_window(world, options, task)
    result.warnings = list(dict.fromkeys(said))
    return result


def _recorded_warnings():
    """A block whose set-up warnings are recorded (one-line texts, in order) and not shown; other
    warnings are shown as before."""
    @contextlib.contextmanager
    def block():
        seen = []
        with warnings.catch_warnings():
            shown = warnings.showwarning

            def record(message, category, filename, lineno, file=None, line=None):
                if isinstance(message, SetupWarning):
                    seen.append(message.one_line())
                else:
                    shown(message, category, filename, lineno, file, line)

            warnings.showwarning = record
            yield seen

    return block()


def _replay_window(world, options: ReplayOptions, task: WindowTask) -> WindowResult:
    from tankcd_cli.io.events import event_line
    from tankcd_cli.io.poses_csv import format_rows
    from tankcd_cli.matching.match import PLACED_BY, STATUS
    from tankcd_cli.replay.effects import resolution
    from tankcd_cli.replay.pipeline import replay_chunks, start_run

    start = time.perf_counter()
    lead, own, trailing, fed = _read_window(world, task)
    run = start_run(world, options, task.has_turret, entities=task.has_entity)
    gathered = None
    if run.vehicles is not None:
        gathered = run.vehicles = _Segments()
    for _ in replay_chunks(run, [], lead=lead):
        pass
    before = (run.between.intervals, run.between.substeps) if run.continuous else (0, 0)
    counts = ReplayCounts()
    steps, tables, keys, records = [], [], [], []
    chunk_of = _chunk_of(task.chunk_starts)
    next_step = _next_rows(*fed)
    for chunk, poses, events in replay_chunks(run, own):
        if chunk is None:
            continue
        tables.append(PoseRows(chunk.t, chunk.entity if chunk.has_entity else None, poses))
        steps.append(chunk.step)
        counts.add(chunk, poses, events)
        for e in events:
            row = next_step(np.array([e.step]))[0] if e.between else e.step
            keys.append((int(chunk_of(np.array([row]))[0]), 0, int(e.step), float(e.t), task.index, len(keys)))
            records.append(e)
    after = (run.between.intervals, run.between.substeps) if run.continuous else (0, 0)
    if trailing is not None:
        for _ in replay_chunks(run, [trailing]):
            pass
    if gathered is not None and gathered.parts:
        t0 = time.perf_counter()
        found = _contacts(world, options, task, gathered.parts, next_step, chunk_of, run.gates)
        run.seconds["vehicles"] += time.perf_counter() - t0  # the local run's time in its vehicle checks
        counts.add(None, None, [e for _, e in found])
        for (k, seq), e in found:
            keys.append((task.windows[k].emit, 1, task.windows[k].index, 0.0, task.index, seq))
            records.append(e)
    lo, hi = world.surface.bounds()
    motion = {"intervals": after[0] - before[0], "substeps": after[1] - before[1], **resolution(world.surface)} \
        if run.continuous else {}
    tally = ReplayTally(counts, run.effects.as_dict(), dict(run.seconds), motion, run.gates.as_dict())
    return WindowResult(task.index, np.concatenate(steps) if steps else np.zeros(0, np.int64),
                        PoseRows.of(tables) if tables else None, keys, records, tally,
                        (tuple(map(float, lo)), tuple(map(float, hi))), world.crs, os.getpid(),
                        round(time.perf_counter() - start, 3))


def _chunk_of(chunk_starts: np.ndarray):
    def chunk_of(steps):
        return np.searchsorted(chunk_starts, steps, side="right") - 1
    return chunk_of


def _next_rows(steps: np.ndarray, codes: np.ndarray):
    """step -> the step of the same entity's next row among those read (what ends its interval)."""
    order = np.lexsort((steps, codes))
    s, c = steps[order], codes[order]
    nxt = np.r_[np.where(c[1:] == c[:-1], s[1:], -1), -1]
    by_step = np.argsort(s)
    sorted_steps = s[by_step]

    def next_step(query):
        return nxt[by_step[np.searchsorted(sorted_steps, query)]]
    return next_step


def _read_window(world, task: WindowTask):
    """A window's rows: (lead chunk, own chunks, trailing chunk, (steps, codes) of all of them), with
    the whole input's entity codes and each entity's first row as its only piece start."""
    index = {name: k for k, name in enumerate(task.names)}
    extra = np.union1d(task.lead, task.trailing)
    fields = ("step", "t", "x", "y", "yaw_deg", "turret_deg", "gun_deg", "line", "piece_start", "entity")
    got = {f: [] for f in fields}
    own_flags = []
    where = "line"
    sources = [None] if task.parts is None else list(task.parts)
    if task.spool is not None:  # converted once by the planning pass: its rows by their steps
        folder, where, first, last = task.spool
        rows = _spooled(folder, np.union1d(np.arange(first, last + 1, dtype=np.int64), extra.astype(np.int64)))
        if not task.has_entity:
            rows["entity"] = np.zeros(len(rows["t"]), np.int64)
        own = (rows["t"] >= task.t0) & (rows["t"] < task.t1)
        keep = own | np.isin(rows["step"], extra)
        for f in fields:
            got[f].append(rows[f][keep])
        own_flags.append(own[keep])
        sources = []
    for part in sources:
        reader = TrajectoryReader(task.trajectory, task.chunk_rows, part, world.crs, task.fmt)
        where = reader.where
        for chunk in reader:
            if task.has_entity:
                to_global = np.array([index[n] for n in chunk.entity_names], np.int64)
                codes = to_global[chunk.entity]
            else:
                codes = np.zeros(len(chunk), np.int64)
            own = (chunk.t >= task.t0) & (chunk.t < task.t1)
            keep = own | np.isin(chunk.step, extra)
            if keep.any():
                for f in fields[:-1]:
                    got[f].append(getattr(chunk, f)[keep])
                got["entity"].append(codes[keep])
                own_flags.append(own[keep])
            if chunk.step[-1] >= task.last_step:
                break
        reader.close()
    if not own_flags or not sum(map(len, own_flags)):
        got = {f: np.zeros(0, np.int64 if f in ("step", "line", "entity") else np.float64) for f in fields}
        own = np.zeros(0, bool)
    else:
        got = {f: np.concatenate(v) for f, v in got.items()}
        own = np.concatenate(own_flags)

    def chunk_of_rows(idx):
        if not len(idx):
            return None
        e = got["entity"][idx]
        # a part's reader starts every entity's motion afresh: only the entity's first row does
        piece = got["step"][idx] == task.first_step[e] if task.parts is not None else got["piece_start"][idx]
        return TrajectoryChunk(got["step"][idx], int(got["line"][idx[0]]), got["t"][idx], got["x"][idx], got["y"][idx],
                               got["yaw_deg"][idx], got["turret_deg"][idx], got["gun_deg"][idx], task.has_turret,
                               got["line"][idx], e, task.names, piece, task.has_entity, where)

    own_idx = np.flatnonzero(own)
    pieces = [chunk_of_rows(own_idx[k:k + task.chunk_rows]) for k in range(0, len(own_idx), task.chunk_rows)]
    lead = chunk_of_rows(np.flatnonzero(~own & np.isin(got["step"], task.lead)))
    trailing = chunk_of_rows(np.flatnonzero(~own & np.isin(got["step"], task.trailing)))
    return lead, pieces, trailing, (got["step"], got["entity"])


def _contacts(world, options, task: WindowTask, parts, next_step, chunk_of, gates=None) -> list:
    """The vehicle contacts of a task's contact windows, each window run with the segments the local
    run had buffered when it closed it, in the buffer's order: ((window, order), Event) pairs."""
    from tankcd_cli.replay.between_rows import Segments
    from tankcd_cli.replay.effects.vehicles import VehicleContacts

    kinds = np.concatenate([np.full(len(s), k, np.int64) for k, s in parts])
    seg = Segments.join([s for _, s in parts])
    arrived = chunk_of(next_step(seg.step))  # the local chunk that read the interval's later row
    contacts = vehicles.VehicleContacts(world, continuous=options.continuous,
                                        gates=GateTally(enabled=options.gates) if gates is None else gates)
    contacts.names = task.names
    first = task.windows[0]

    def add(idx):
        for k in np.unique(kinds[idx]):
            sel = idx[kinds[idx] == k]
            contacts.add(world.kinds[int(k)], seg.take(sel))

    # the buffer the local run held at the first window: what it kept past the window before (by
    # kind), then what it read since, chunk by chunk
    kept = np.flatnonzero((arrived <= task.kept_until) & (seg.t1 >= first.w0))
    add(kept[np.lexsort((np.arange(len(kept)), seg.t0[kept], seg.entity[kept], arrived[kept], kinds[kept]))])
    found = []
    done = task.kept_until
    for k, w in enumerate(task.windows):
        if w.emit > done:
            new = np.flatnonzero((arrived > done) & (arrived <= w.emit))
            new = new[np.lexsort((np.arange(len(new)), seg.t0[new], seg.entity[new], kinds[new], arrived[new]))]
            for c in np.unique(arrived[new]):
                add(new[arrived[new] == c])
            done = w.emit
        found += [((k, j), e) for j, e in enumerate(contacts.close_window(w.w0, w.w1, w.last))]
    return found


# --- the whole exercise -------------------------------------------------------------------------

class _Extent:
    """The terrain's extent as a task reported it (what the warning about rows off it needs)."""

    def __init__(self, lo, hi):
        self.lo, self.hi = np.asarray(lo), np.asarray(hi)

    def bounds(self):
        return self.lo, self.hi


def run_windows(trajectory: str, outputs: ReplayOutputs, runner: Callable, plan: WindowPlan,
                options: ReplayOptions = ReplayOptions(), progress: Callable[[int], None] | None = None
                ) -> ReplaySummary:
    """Write the poses and events of ``plan``'s tasks, joined in the local run's order, from
    ``runner(tasks, consume)`` (which runs every task and gives each result to ``consume``, in any
    order: ``window_runner``); returns the replay's summary.

    The outputs are a run in one piece's, through its writers (``replay.outputs.replay_outputs``:
    every format of ``OUTPUT_FORMATS``), whose Parquet metadata is ``runner.metadata(trajectory,
    time_origin)`` (``replay.outputs.replay_metadata`` of the world the tasks run in). The plan's
    converted rows (``WindowPlan.close``) are removed after."""
    try:
        return _run_windows(trajectory, outputs, runner, plan, options, progress)
    finally:
        plan.close()


def _run_windows(trajectory, outputs, runner, plan, options, progress) -> ReplaySummary:
    start = time.perf_counter()
    join = _Join(plan)
    join.chunk_rows = options.chunk_rows
    origin = utc_text(plan.time_origin) if plan.time_origin is not None else None

    def metadata():
        return runner.metadata(trajectory, origin)

    with collected_warnings() as said:
        with replay_outputs(outputs, plan.has_entity, metadata) as (poses_out, events_out):
            join.poses_out, join.events_out, join.progress = poses_out, events_out, progress
            runner(plan.tasks, join.take)
            join.flush_all()
            for out in (poses_out, events_out):
                if out is not None:
                    out.finish()
        if join.extent is not None:
            warn_if_beside(join.extent, join.tally.counts, trajectory, join.crs)
    entities = plan.entities if options.continuous else (1 if join.tally.counts.rows else 0)
    summary = summary_of(join.tally, options.continuous, time.perf_counter() - start, entities)
    summary.warnings = list(dict.fromkeys(plan.warnings + list(said)))
    summary.time_origin = origin
    return summary


class _Join:
    """The tasks' results, written in order as soon as nothing later can come before them."""

    def __init__(self, plan: WindowPlan):
        self.plan = plan
        n = len(plan.tasks)
        big = np.iinfo(np.int64).max
        # what a task not yet written may still hold: its least step, its least chunk
        self.step_after = np.r_[np.minimum.accumulate(plan.min_step[::-1])[::-1][1:], big] if n else np.zeros(0)
        self.chunk_after = np.r_[np.minimum.accumulate(plan.min_chunk[::-1])[::-1][1:], big] if n else np.zeros(0)
        self.waiting: dict = {}
        self.next = 0
        self.rows = []  # (steps, PoseRows) not yet written
        self.events = []  # (key, Event) not yet written
        self.tally = ReplayTally()
        self.extent = None
        self.crs = ""
        self.poses_out = self.events_out = self.progress = None
        self.chunk_rows = 65536  # the rows handed to the poses writer at a time (the local run's chunk)
        self.said = set(plan.warnings)  # warnings said already: the plan's, then the tasks' as they come

    def take(self, result: WindowResult) -> None:
        for line in result.warnings:  # each once, whichever task and process raised it
            if line not in self.said:
                self.said.add(line)
                warn(None, line)
        self.waiting[result.index] = result
        while self.next in self.waiting:
            r = self.waiting.pop(self.next)
            self._add(r)
            self._write(self.step_after[self.next], self.chunk_after[self.next])
            self.next += 1
            if self.progress is not None:
                self.progress(self.tally.counts.rows)

    def _add(self, r: WindowResult) -> None:
        self.tally.merge(r.tally)
        if r.bounds and self.extent is None:
            self.extent = _Extent(*r.bounds)
            self.crs = r.crs
        if len(r.steps):
            self.rows.append((r.steps, r.pose_rows))
        self.events += list(zip(r.event_keys, r.event_lines))

    def _write(self, step_limit, chunk_limit) -> None:
        if self.rows:
            ready_steps, ready_rows, rest = [], [], []
            for steps, rows in self.rows:
                cut = int(np.searchsorted(steps, step_limit, side="left"))
                if cut:
                    ready_steps.append(steps[:cut])
                    ready_rows.append(rows.take(0, cut))
                if cut < len(steps):
                    rest.append((steps[cut:], rows.take(cut, len(steps))))
            self.rows = rest
            if ready_steps and self.poses_out is not None:
                steps = np.concatenate(ready_steps)
                if len(ready_steps) > 1:
                    order = np.argsort(steps, kind="stable")
                    self._write_rows(steps[order], PoseRows.merged(ready_rows, order))
                else:
                    self._write_rows(steps, ready_rows[0])
        if self.events:
            self.events.sort(key=lambda kv: kv[0])
            cut = 0
            while cut < len(self.events) and self.events[cut][0][0] < chunk_limit:
                cut += 1
            if cut and self.events_out is not None:
                self.events_out.write([record for _, record in self.events[:cut]])
            del self.events[:cut]

    def _write_rows(self, steps: np.ndarray, table: PoseRows) -> None:
        """Pose rows to the poses writer as the run in one piece hands it a chunk, ``chunk_rows`` at a
        time (a Parquet output's row groups)."""
        names = self.plan.tasks[0].names if self.plan.tasks else ()
        size = max(1, self.chunk_rows)
        for lo in range(0, len(steps), size):
            part = table.take(lo, lo + size)
            chunk = SimpleNamespace(step=steps[lo:lo + size], t=part.t, has_entity=self.plan.has_entity,
                                    entity=part.entity, entity_names=names)
            self.poses_out.write(chunk, part.poses)

    def flush_all(self) -> None:
        big = np.iinfo(np.int64).max
        self._write(big, big)
        if self.waiting:
            raise RuntimeError(f"window tasks {sorted(self.waiting)} finished but the ones before them did not")
        if self.next != len(self.plan.tasks):
            raise RuntimeError(f"{len(self.plan.tasks) - self.next} window tasks gave no result")


def window_runner(world: TaskWorld, executor: Executor = Executor(), loaded=None,
                  say: Callable[[str], None] | None = None):
    """A runner (``run_windows``) that runs the tasks on ``executor``: here, in its forked
    processes (``loaded``, the world already loaded here, is what they share), or on its Dask
    cluster (each worker loads ``world`` once; a window whose worker is lost runs again on another:
    its result is all it gives, nothing is written until the results are joined). At most two
    tasks per worker are out beyond the oldest not joined, so that results wait to be joined only
    while the one before them runs. ``runner.metadata(trajectory, time_origin)``: the Parquet
    outputs' metadata, of the loaded world here, of a worker's on a cluster."""
    if loaded is not None:
        keep_loaded(world.spec, loaded)
    executor = dataclasses.replace(executor, ahead=max(2, 2 * executor.jobs), retries=3)

    def runner(tasks, consume):
        executor.run(run_window, world, tasks, consume, key=lambda task, k: f"tankcd-window-{task.index}", say=say)

    def metadata(trajectory, time_origin=None):
        if not executor.scheduler:
            return window_metadata(world, trajectory, time_origin)
        # the world is loaded on the workers only: one of them describes it (and hashes the inputs)
        with dask_client(executor.scheduler) as client:
            return client.submit(window_metadata, world, trajectory, time_origin, pure=False, retries=3).result()

    runner.metadata = metadata
    return runner


def in_process(world, options: ReplayOptions):
    """A runner (``run_windows``) that replays the tasks one after the other here, in ``world``
    (loaded)."""
    return window_runner(TaskWorld(world.spec, options), loaded=world)


def window_metadata(world: TaskWorld, trajectory: str, time_origin: str | None = None) -> dict:
    """The Parquet outputs' metadata, on a worker: ``replay.outputs.replay_metadata`` of the world
    loaded once per process, as the tasks load it."""
    return replay_metadata(load_world_once(world.spec), [trajectory], world.options, time_origin=time_origin)
