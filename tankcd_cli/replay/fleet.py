"""Replay fleets of trajectories: in parallel processes on one machine, or on a Dask cluster.

The tasks run where ``replay.executor`` runs them (the world loaded once per process, never
shipped with a task: a task is three strings, trajectory, poses path, events path, plus the
world's description, ``TaskWorld``).

Outputs are written atomically, one poses and one events file per trajectory (in one of
``replay.outputs.OUTPUT_FORMATS``: CSV and JSON Lines, or both Parquet),
so a task that dies (worker lost, killed) leaves no partial file, and the
retry writes the whole file again: no row is lost or written twice.
"""

from __future__ import annotations

import glob
import json
import os
import time
import dataclasses
from dataclasses import dataclass
from typing import Callable

from tankcd_cli.errors import InputError, warn
from tankcd_cli.io.atomic import atomic_path
from tankcd_cli.io.trajectory import has_entity_column, split_trajectory
from tankcd_cli.replay.executor import Executor, TaskWorld, load_world_once, worker_threads
from tankcd_cli.replay.outputs import OUTPUT_FORMATS, output_format
from tankcd_cli.replay.records import EVENT_KINDS, KINDS, ReplayOutputs
from tankcd_cli.replay.run import joined_summary, run_replay


@dataclass(frozen=True)
class Task:
    """One unit of work: a trajectory (or a part of one) and where its outputs go. A part writes
    beside the fleet's outputs and names the whole trajectory's outputs it is joined into."""

    trajectory: str
    poses: str
    events: str
    part: object = None  # tankcd_cli.io.trajectory.TrajectoryPart
    whole_poses: str | None = None
    whole_events: str | None = None


def is_listing(item: str) -> bool:
    """Whether a trajectory argument is a list file (``@runs.txt``), not a file of that name."""
    return item.startswith("@") and not os.path.exists(item)


def is_pattern(item: str) -> bool:
    """Whether a trajectory argument is a glob (``runs/*.csv``), not a file of that name."""
    return any(ch in item for ch in "*?[") and not os.path.exists(item)


def names_a_fleet(items) -> bool:
    """Whether trajectory arguments name a fleet by themselves: several, or a glob or a list file
    (``replay_mode``'s rule; ``--out-dir`` and the rest say it too)."""
    items = list(items)
    return len(items) > 1 or any(is_listing(t) or is_pattern(t) for t in items)


def expand_trajectories(items: list[str]) -> list[str]:
    """Paths, globs (``runs/*.csv``) and list files (``@runs.txt``: one path per line, relative to
    the list, ``#`` comments) into a list of trajectory paths, in the order given, without repeats."""
    out: list[str] = []
    for item in items:
        if is_listing(item):  # a file whose name happens to hold * ? [ or @ is that file
            listing = item[1:]
            try:
                with open(listing, encoding="utf-8-sig") as fh:
                    lines = [ln.strip() for ln in fh]
            except OSError as exc:
                raise InputError(listing, f"cannot read the list of trajectories: {exc.strerror or exc}") from None
            base = os.path.dirname(os.path.abspath(listing))
            found = [os.path.join(base, ln) if not os.path.isabs(ln) else ln for ln in lines
                     if ln and not ln.startswith("#")]
        elif is_pattern(item):
            found = sorted(glob.glob(item, recursive=True))
            if not found:
                raise InputError(item, "the pattern matches no file")
            written = [p for p in found if written_by_tankcd(p)]
            if written:
                warn(item, f"skipped {len(written)} file{'s' if len(written) > 1 else ''} tankcd wrote (poses, not "
                           f"trajectories), such as {written[0]}")
                found = [p for p in found if p not in written]
                if not found:
                    raise InputError(item, "the pattern matches only files tankcd wrote (poses), no trajectory")
        else:
            found = [item]
        for path in found:
            if path not in out:
                out.append(path)
    if not out:
        raise InputError(",".join(items) or "-", "no trajectories given")
    return out


def written_by_tankcd(path: str) -> bool:
    """Whether a file is one of tankcd's outputs by its first line: a poses CSV's header (``step,``
    then the pose's columns, ``qw`` and ``matcher`` among them), or an events JSON Lines record; or
    a Parquet file whose footer (its last bytes: the metadata, then its length and ``PAR1``) names
    ``tankcd.version``."""
    try:
        with open(path, "rb") as fh:
            if fh.read(4) == b"PAR1":
                return _parquet_footer_names_tankcd(fh)
            fh.seek(0)
            head = fh.readline(4096).decode("utf-8-sig", errors="replace").strip()
    except OSError:
        return False
    if head.startswith("{") and '"kind"' in head and '"step"' in head:
        return True
    cols = [c.strip().lower() for c in head.split(",")]
    return bool(cols) and cols[0] == "step" and {"qw", "matcher", "status"} <= set(cols)


def _parquet_footer_names_tankcd(fh) -> bool:
    """Whether an open Parquet file's footer holds tankcd's metadata key (read without pyarrow)."""
    import struct

    fh.seek(0, os.SEEK_END)
    size = fh.tell()
    if size < 12:
        return False
    fh.seek(size - 8)
    length, magic = struct.unpack("<I4s", fh.read(8))
    if magic != b"PAR1" or length > size - 12:
        return False
    fh.seek(size - 8 - length)
    return b"tankcd.version" in fh.read(length)


def plan_tasks(trajectories: list[str], out_dir: str, split_lines: int | None = None,
               out_format: str = "csv") -> list[Task]:
    """One task per trajectory, outputs named after the input (``a.csv`` -> ``a.poses.csv``,
    ``a.events.jsonl``; with ``out_format`` "parquet", ``a.poses.parquet`` and ``a.events.parquet``);
    inputs of the same name from different directories get the directory too.

    A trajectory longer than ``split_lines`` lines becomes one task per part of that many lines
    (read on their own, joined in order when all are done), so that one huge log can use many
    workers.
    """
    if out_format not in OUTPUT_FORMATS:
        raise ValueError(f"unknown output format {out_format!r}; choose one of {', '.join(OUTPUT_FORMATS)}")
    poses_suffix, events_suffix = OUTPUT_FORMATS[out_format].fleet_suffixes
    stems = [os.path.splitext(os.path.basename(p))[0] for p in trajectories]
    tasks = []
    for path, stem in zip(trajectories, stems):
        if stems.count(stem) > 1:
            parent = os.path.basename(os.path.dirname(os.path.abspath(path))) or "root"
            stem = f"{parent}__{stem}"
        out = os.path.abspath(out_dir)  # workers elsewhere (a cluster) may run in another directory
        tasks.append(Task(os.path.abspath(path), os.path.join(out, stem + poses_suffix),
                          os.path.join(out, stem + events_suffix)))
    names = [t.poses for t in tasks]
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise InputError(dup, "two trajectories would write the same output; rename one")
    if not split_lines:
        return tasks
    return [piece for task in tasks for piece in _split(task, split_lines)]


def _split(task: Task, split_lines: int) -> list[Task]:
    try:
        big = os.path.getsize(task.trajectory) > split_lines * 16  # no row is shorter than "t,x,y,yaw" + digits
    except OSError:
        return [task]  # the task itself will say what is wrong with the file
    if not big or has_entity_column(task.trajectory):
        # an exercise is one task: parts cut by lines would miss (or repeat) contacts between
        # vehicles whose rows straddle a cut
        return [task]
    try:
        parts = split_trajectory(task.trajectory, split_lines)
    except InputError:
        return [task]
    if len(parts) < 2:
        return [task]
    folder = os.path.join(os.path.dirname(task.poses), ".parts")
    poses_suffix, events_suffix = output_format(task.poses).fleet_suffixes
    stem = os.path.basename(task.poses)[: -len(poses_suffix)]
    return [Task(task.trajectory, os.path.join(folder, f"{stem}.{k:05d}{poses_suffix}"),
                 os.path.join(folder, f"{stem}.{k:05d}{events_suffix}"), part, task.poses, task.events)
            for k, part in enumerate(parts)]


@dataclass
class TaskResult:
    """What one task (a trajectory, or a part of one) did: its outputs, its status (``ok``,
    ``bad_input``, ``internal_error``) and error line, the replay's summary (``ReplaySummary``;
    None where it failed), the first row's line and the first and last times (what joining parts
    checks), the worker's pid(s), the task's seconds and, for a joined trajectory, its parts; for an
    internal error, the worker's formatted traceback (``traceback``: what ``-v`` shows; not in
    fleet.json)."""

    trajectory: str
    poses: str
    events: str
    status: str = "ok"
    error: str | None = None
    summary: object = None
    first_line: int | None = None
    t_first: float | None = None
    t_last: float | None = None
    pid: object = None
    task_seconds: float = 0.0
    parts: int | None = None
    traceback: str | None = None

    def as_dict(self) -> dict:
        """As a line of fleet.json's ``results``: the summary's fields beside the task's."""
        out = {"trajectory": self.trajectory, "poses": self.poses, "events": self.events, "pid": self.pid,
               "status": self.status, "task_seconds": self.task_seconds}
        if self.parts is not None:
            out["parts"] = self.parts
        if self.summary is not None:
            out.update(self.summary.as_dict())
            out.update(first_line=self.first_line, t_first=self.t_first, t_last=self.t_last)
        if self.error is not None:
            out["error"] = self.error
        return out


def run_task(world: TaskWorld, task: Task, kernel_threads: int | None = None) -> TaskResult:
    """Replay one trajectory of the fleet (``replay.run.run_replay``); never raises: a failure is
    reported in the result.

    kernel_threads : threads for the compiled kernels of this task (OpenMP's setting is per calling
    thread, and a Dask worker runs tasks in its own threads); None keeps the process's setting.
    """
    if kernel_threads is not None:
        worker_threads(kernel_threads)
    start = time.perf_counter()
    result = TaskResult(task.trajectory, task.poses, task.events, pid=os.getpid())
    try:
        loaded = load_world_once(world.spec)
        if task.part is not None:
            os.makedirs(os.path.dirname(task.poses), exist_ok=True)
        ends = {}

        def remember(chunk, poses, events):
            if chunk is None or not len(chunk):  # None: the vehicles' last contacts, after the last chunk
                return
            if "first_line" not in ends:
                ends.update(first_line=int(chunk.line[0]), t_first=float(chunk.t[0]))
            ends["t_last"] = float(chunk.t[-1])

        result.summary = run_replay(loaded, task.trajectory, ReplayOutputs(task.poses, task.events), world.options,
                                    part=task.part, observe=remember)
        result.first_line, result.t_first, result.t_last = (ends.get(k) for k in ("first_line", "t_first", "t_last"))
        if task.part is not None and result.summary.rows != task.part.rows:
            raise RuntimeError(f"part of {task.trajectory} read {result.summary.rows} rows, the split counted "
                               f"{task.part.rows}")
    except InputError as exc:
        result.status, result.error, result.summary = "bad_input", exc.one_line(), None
    except Exception as exc:  # noqa: BLE001 - a bug in one task must not stop the fleet; it is reported
        import traceback

        from tankcd_cli.errors import printable

        result.status, result.summary = "internal_error", None
        result.error = printable(f"{type(exc).__name__}: {exc}".splitlines()[0])
        result.traceback = traceback.format_exc()  # formatted here: a traceback object does not travel
    result.task_seconds = round(time.perf_counter() - start, 3)
    return result


@dataclass
class FleetSummary:
    """A fleet's closing summary (docs/formats.md, "fleet.json"): counts summed over the
    trajectories that finished, the failures, where it ran, and every trajectory's result."""

    trajectories: int
    tasks: int
    ok: int
    failed: int
    rows: int
    collisions: dict
    between: dict
    off_terrain: int
    vehicle_contacts: int
    seconds: float
    rows_per_second: float | None
    ran_on: str
    world: dict
    failures: list
    results: list
    warnings: list = dataclasses.field(default_factory=list)  # every trajectory's set-up warnings, each once

    @property
    def collided(self) -> bool:
        return bool(sum(self.collisions.values()) or self.vehicle_contacts
                    or sum(v for k, v in self.between.items() if k != "off_terrain"))

    def as_dict(self, results: bool = True) -> dict:
        out = {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "results"}
        if results:
            out["results"] = [r.as_dict() for r in self.results]
        return out


# --- fan-out ------------------------------------------------------------------------------

def run_fleet(world: TaskWorld, tasks: list[Task], jobs: int = 1, scheduler: str | None = None,
              progress: Callable[[str], None] | None = None,
              on_result: Callable[[TaskResult], None] | None = None) -> FleetSummary:
    """Run every task (in-process, in ``jobs`` forked processes, or on the Dask cluster at
    ``scheduler``: ``replay.executor``) and return the fleet summary."""
    start = time.perf_counter()
    done = on_result or (lambda r: None)
    results = []

    def consume(result: TaskResult) -> None:
        results.append(result)
        done(result)

    executor = Executor(jobs=1 if len(tasks) == 1 else jobs, scheduler=scheduler)
    executor.run(run_task, world, tasks, consume, lost=_lost,
                 key=lambda t, k: f"tankcd-{os.path.basename(t.poses)}-{k}", say=progress)
    how = executor.ran_on
    results = _join_parts(tasks, results)
    order = {path: k for k, path in enumerate(dict.fromkeys(t.trajectory for t in tasks))}
    results.sort(key=lambda r: order[r.trajectory])
    ok = [r for r in results if r.status == "ok"]
    failed = [r for r in results if r.status != "ok"]
    rows = sum(r.summary.rows for r in ok)
    warnings = list(dict.fromkeys(w for r in ok for w in r.summary.warnings))
    if scheduler:  # said on the workers, where no one reads them: here, each once
        for line in warnings:
            warn(None, line)
    seconds = time.perf_counter() - start
    return FleetSummary(
        trajectories=len(results), tasks=len(tasks), ok=len(ok), failed=len(failed), rows=rows,
        collisions={k: sum(r.summary.collisions[k] for r in ok) for k in KINDS},
        between={k: sum(r.summary.between.get(k, 0) for r in ok) for k in EVENT_KINDS},
        off_terrain=sum(r.summary.off_terrain for r in ok),
        vehicle_contacts=sum(r.summary.vehicle_contacts for r in ok), seconds=round(seconds, 3),
        rows_per_second=round(rows / seconds, 1) if seconds > 0 else None, ran_on=how, world=world.describe(),
        failures=[{"trajectory": r.trajectory, "status": r.status, "error": r.error} for r in failed],
        results=results, warnings=warnings)


def _join_parts(tasks: list[Task], results: list[TaskResult]) -> list[TaskResult]:
    """Join the parts of split trajectories, in order, into their whole outputs (atomically), after
    checking that time does not go back across a cut; one result per trajectory."""
    by_poses = {r.poses: r for r in results}
    part_outputs = {t.poses for t in tasks if t.part is not None}
    whole = [r for r in results if r.poses not in part_outputs]
    groups: dict = {}
    for t in tasks:
        if t.part is not None:
            groups.setdefault(t.whole_poses, []).append(t)
    for target, parts in groups.items():
        rs = [by_poses[t.poses] for t in parts]
        first, error, status, trace = parts[0], None, "ok", None
        for k, r in enumerate(rs):
            prev = rs[k - 1] if k else None
            if prev is not None and prev.status == "ok" and r.status == "ok" and r.t_first is not None \
                    and prev.t_last is not None and r.t_first < prev.t_last:
                error = InputError(first.trajectory, f"time goes back ({r.t_first!r} after {prev.t_last!r}); "
                                                     "t must be non-decreasing",
                                   where=f"line {r.first_line} column t").one_line()
                status = "bad_input"
                break
            if r.status != "ok":
                error, status, trace = r.error, r.status, r.traceback
                break
        joined = TaskResult(first.trajectory, target, first.whole_events, parts=len(parts),
                            task_seconds=round(sum(r.task_seconds for r in rs), 3),
                            pid=sorted({r.pid for r in rs if r.pid is not None}))
        try:
            if error is None:
                output_format(target).join(target, first.whole_events, [(t.poses, t.events) for t in parts])
                joined.summary = joined_summary([r.summary for r in rs])
                joined.first_line, joined.t_first, joined.t_last = rs[0].first_line, rs[0].t_first, rs[-1].t_last
            else:
                joined.status, joined.error, joined.traceback = status, error, trace
        except InputError as exc:
            joined.status, joined.error = "bad_input", exc.one_line()
        finally:
            for t in parts:
                for path in (t.poses, t.events):
                    if os.path.exists(path):
                        os.unlink(path)
        whole.append(joined)
    for folder in {os.path.dirname(t.poses) for t in tasks if t.part is not None}:
        try:
            os.rmdir(folder)
        except OSError:
            pass  # something else is in it (a killed worker's temporary file): leave it
    return whole


def _lost(task: Task, exc: BaseException) -> TaskResult:
    """The result of a task whose worker died under it."""
    import traceback

    return TaskResult(task.trajectory, task.poses, task.events, status="internal_error",
                      error=f"{task.trajectory}: its worker was lost: {type(exc).__name__}: {exc}"[:300],
                      traceback="".join(traceback.format_exception(type(exc), exc, exc.__traceback__)))


def write_summary(path: str, fleet: FleetSummary) -> None:
    """fleet.json, written atomically."""
    with atomic_path(path, ".json") as tmp:
        with open(tmp, "w") as fh:
            json.dump(fleet.as_dict(), fh, indent=2, default=str)
            fh.write("\n")
