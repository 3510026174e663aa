"""Where a replay's tasks run: in this process, in forked worker processes, or on a Dask cluster.

A fleet's trajectories (``replay.fleet``) and an exercise's time windows (``replay.windows``) are
tasks of one shape: ``fn(world, task, kernel_threads)`` with ``world`` a ``TaskWorld`` (text: the
world's spec and the replay's options, what travels to the workers) and ``task`` a small record.
The world is loaded once per process, never shipped with a task: on one machine the parent loads
it and forks its workers, which share its arrays copy-on-write (read-only: no page is copied); on
a cluster every worker loads it from the shared path once and keeps it for all its tasks.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from dataclasses import asdict, dataclass
from typing import Callable, Iterator, Sequence

from tankcd_cli.errors import InputError
from tankcd_cli.replay.records import ReplayOptions
from tankcd_cli.replay.world import WorldSpec

DASK_MISSING = "--scheduler needs Dask: pip install 'tankcd[dask]'"


@dataclass(frozen=True)
class TaskWorld:
    """What every task of a run replays against, as text (it travels to the workers): the world's
    spec and the replay's options."""

    spec: WorldSpec
    options: ReplayOptions = ReplayOptions()

    def describe(self) -> dict:
        """fleet.json's ``world``: the spec's fields and the options'."""
        return {**asdict(self.spec), **{k: v for k, v in asdict(self.options).items() if k != "chunk_rows"}}


# --- the per-process world ----------------------------------------------------------------

_LOADED: dict = {}  # WorldSpec -> World: one per process, loaded on first use
_LOADING = threading.Lock()  # a Dask worker runs tasks in threads: one of them loads, the others wait


def load_world_once(spec: WorldSpec, progress: Callable[[str], None] | None = None):
    """The world of ``spec``, loaded once per process (a new spec replaces the old one)."""
    with _LOADING:
        if spec not in _LOADED:
            world = spec.load(progress)
            _LOADED.clear()
            _LOADED[spec] = world
        return _LOADED[spec]


def keep_loaded(spec: WorldSpec | None, world) -> None:
    """Make ``world`` (already loaded here) the process's world of ``spec``: the tasks run here and
    the workers forked after this find it instead of loading it again."""
    with _LOADING:
        _LOADED.clear()
        _LOADED[spec] = world


def worker_threads(threads: int) -> None:
    """Each of N workers gets cores / N compiled-kernel threads: no oversubscription."""
    from tankcd_cli.threads import set_num_threads

    set_num_threads(threads)


@contextlib.contextmanager
def dask_client(scheduler: str, say: Callable[[str], None] | None = None) -> Iterator:
    """A ``distributed.Client`` connected to ``scheduler`` for the block (closed after); an
    ``InputError`` naming the address when Dask is not installed or the scheduler is not reached."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError(scheduler, DASK_MISSING) from None
    if say is not None:
        say(f"connecting to the Dask scheduler at {scheduler}")
    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise InputError(scheduler, f"cannot reach the Dask scheduler: {exc}") from None
    with client:
        yield client


@dataclass(frozen=True)
class Executor:
    """How tasks run: here one after the other (``jobs`` 1, no ``scheduler``), in ``jobs`` forked
    processes, or on the Dask cluster at ``scheduler``.

    ahead : at most this many tasks out beyond the oldest one not finished (None: all at once);
        what bounds the results waiting to be joined in order
    retries : a Dask task's retries on other workers when its worker is lost
    """

    jobs: int = 1
    scheduler: str | None = None
    ahead: int | None = None
    retries: int = 2

    @property
    def ran_on(self) -> str:
        """Where the tasks ran, as fleet.json's ``ran_on`` says it."""
        if self.scheduler:
            return f"dask at {self.scheduler}"
        return f"{self.jobs} processes" if self.jobs > 1 else "1 process"

    def run(self, fn: Callable, world: TaskWorld, tasks: Sequence, consume: Callable,
            lost: Callable | None = None, key: Callable[[object, int], str] | None = None,
            say: Callable[[str], None] | None = None) -> None:
        """Run ``fn(world, task[, kernel_threads])`` for every task and hand each result to
        ``consume`` as it comes (in any order).

        lost(task, exc) : the result of a task whose worker died under it (None: the error is raised)
        key(task, k) : a Dask task's key prefix (unique per run: a time stamp is added)
        say : progress lines (loading the world, connecting to the cluster)
        """
        tasks = list(tasks)
        if self.scheduler:
            self._on_dask(fn, world, tasks, consume, lost, key, say)
        elif self.jobs <= 1 or len(tasks) <= 1:
            load_world_once(world.spec, say)
            for task in tasks:
                consume(fn(world, task))
        else:
            self._on_processes(fn, world, tasks, consume, lost, say)

    def _on_processes(self, fn, world, tasks, consume, lost, say) -> None:
        import multiprocessing
        from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

        # the parent loads the world with numpy only (no compiled kernel has started threads yet),
        # then forks: the workers see the same arrays, shared copy-on-write and never written
        load_world_once(world.spec, say)
        context = multiprocessing.get_context("fork")
        threads = max(1, (os.cpu_count() or 1) // self.jobs)
        with ProcessPoolExecutor(max_workers=self.jobs, mp_context=context, initializer=worker_threads,
                                 initargs=(threads,)) as pool:
            self._drain(tasks, lambda task: pool.submit(fn, world, task),
                        lambda futures: wait(futures, return_when=FIRST_COMPLETED).done, consume, lost)

    def _on_dask(self, fn, world, tasks, consume, lost, key, say) -> None:
        from distributed import wait

        stamp = time.time_ns()
        with dask_client(self.scheduler, say) as client:
            ahead = self.ahead
            if ahead is not None:
                ahead = max(ahead, 2 * sum(client.nthreads().values()))
            counter = iter(range(len(tasks)))

            def submit(task):
                # a task is a few strings; the world is loaded by each worker from the shared path, once;
                # a worker lost mid-task has its tasks run again elsewhere (atomic outputs: no partial file);
                # one kernel thread per task: a cluster runs a worker thread per core
                name = key(task, next(counter)) if key is not None else f"tankcd-task-{next(counter)}"
                return client.submit(fn, world, task, 1, pure=False, retries=self.retries, key=f"{name}-{stamp}")

            self._drain(tasks, submit, lambda futures: wait(futures, return_when="FIRST_COMPLETED").done, consume,
                        lost, ahead)

    def _drain(self, tasks, submit, finished, consume, lost, ahead: int | None = -1) -> None:
        """Submit the tasks (at most ``ahead`` beyond the oldest not finished), hand each result on."""
        ahead = self.ahead if ahead == -1 else ahead
        limit = len(tasks) if ahead is None else max(1, ahead)
        running: dict = {}  # future -> the task's place
        done = set()
        oldest = submitted = 0
        while submitted < len(tasks) or running:
            while submitted < len(tasks) and submitted < oldest + limit:
                running[submit(tasks[submitted])] = submitted
                submitted += 1
            for fut in finished(list(running)):
                k = running.pop(fut)
                try:
                    result = fut.result()
                except Exception as exc:  # noqa: BLE001 - a worker process died (killed, out of memory)
                    if lost is None:
                        raise
                    result = lost(tasks[k], exc)
                consume(result)
                done.add(k)
                while oldest in done:
                    done.discard(oldest)
                    oldest += 1
