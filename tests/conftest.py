import threading
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from tankcd_cli.cli.main import cli


@pytest.fixture
def run(tmp_path, monkeypatch):
    """Run a tankcd command in a temporary directory; returns the click Result.

    stdout and stderr are kept apart, as scripts see them.
    """
    monkeypatch.chdir(tmp_path)

    def invoke(*args, input=None):
        runner = CliRunner()
        return runner.invoke(cli, [str(a) for a in args], input=input, catch_exceptions=False)
    return invoke


def write_asc(path, z, cellsize=1.0, xll=0.0, yll=0.0, nodata=None, corner=False):
    """Write an ESRI ASCII grid; z[0] is the NORTH row, as in the file."""
    z = np.asarray(z, dtype=float)
    lines = [f"ncols {z.shape[1]}", f"nrows {z.shape[0]}",
             f"{'xllcorner' if corner else 'xllcenter'} {xll!r}", f"{'yllcorner' if corner else 'yllcenter'} {yll!r}",
             f"cellsize {cellsize!r}"]
    if nodata is not None:
        lines.append(f"NODATA_value {nodata}")
    lines += [" ".join(repr(float(v)) for v in row) for row in z]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_obj(path, vertices, faces):
    with open(path, "w") as fh:
        for v in vertices:
            fh.write("v %r %r %r\n" % tuple(float(c) for c in v))
        for f in faces:
            fh.write("f %d %d %d\n" % tuple(int(i) + 1 for i in f))
    return path


def trajectory_columns(t, x, y, yaw, turret=None, gun=None) -> dict:
    """A trajectory's columns as arrays (``t``, ``x``, ``y``, ``yaw_deg``, ``turret_deg``,
    ``gun_deg``; turret and gun 0 when not given)."""
    n = len(t)
    return {"t": np.asarray(t, float), "x": np.asarray(x, float), "y": np.asarray(y, float),
            "yaw_deg": np.asarray(yaw, float), "turret_deg": np.zeros(n) if turret is None else np.asarray(turret),
            "gun_deg": np.zeros(n) if gun is None else np.asarray(gun)}


def start_dask_cluster(folder, workers=2):
    """A local Dask cluster as a user starts one: a scheduler and ``workers`` single-threaded workers
    without nannies (a killed worker stays dead), each a process in its own session. Returns
    (address, worker processes, every process); stop them with ``stop_processes``."""
    import json
    import subprocess
    import sys
    import time

    def start(args):
        return subprocess.Popen([sys.executable, "-m", *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)

    info = Path(folder) / "scheduler.json"
    procs = [start(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                    "--scheduler-file", str(info)])]
    try:
        for _ in range(200):
            if info.exists() and info.stat().st_size:
                break
            time.sleep(0.05)
        pool = [start(["distributed.cli.dask_worker", "--scheduler-file", str(info), "--nthreads", "1", "--no-nanny",
                       "--no-dashboard"]) for _ in range(workers)]
        procs += pool
        return json.loads(info.read_text())["address"], pool, procs
    except BaseException:
        stop_processes(procs)
        raise


def busy_worker(client, workers, job, what, tries=3000):
    """The worker process (of ``workers``) that first holds a task of ``job``'s run, polled every
    10 ms up to ``tries`` times; fails if ``job`` ends first or no task ever reaches a worker
    (``what`` names the tasks in that message)."""
    import os
    import time

    client.wait_for_workers(len(workers), timeout=60)
    pids = client.run(os.getpid)  # {worker address: pid}
    for _ in range(tries):
        busy = [w for w, keys in client.processing().items() if keys]
        if busy:
            victim = next(p for p in workers if p.pid == pids[busy[0]])
            assert job.poll() is None, "the run ended before the kill"
            return victim
        assert job.poll() is None, job.communicate()
        time.sleep(0.01)
    raise AssertionError(f"no {what} ever ran on a worker")


def stop_processes(procs):
    """Kill every process (and its session) still running."""
    import os
    import signal

    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)


class FullDisk:
    """A text stream whose every write fails as on a full disk (ENOSPC); everything else is the
    stream's own."""

    def __init__(self, fh):
        self.fh = fh

    def write(self, text):
        import errno
        import os

        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def __getattr__(self, name):
        return getattr(self.fh, name)


class PipeReader(threading.Thread):
    """Reads a named pipe (``path``) or a pipe's read end (``fd``) to its end in a thread, as `cat`
    would: ``start()``, then ``join()`` and ``data``."""

    def __init__(self, path=None, fd=None):
        super().__init__(daemon=True)
        self.path, self.fd, self.data = path, fd, b""

    def run(self):
        import os

        with (open(self.path, "rb") if self.path else os.fdopen(self.fd, "rb")) as fh:
            self.data = fh.read()
