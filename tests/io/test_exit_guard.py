"""The SIGTERM guard: temporary outputs registered while pending, and removed by the forced exit."""

import os
import signal
import subprocess
import sys
import time

import pytest

pytest.importorskip("tankcd_cli.io._exit_guard")

SCRIPT = """
import os, signal, sys
import numpy as np
from tankcd_cli.io.atomic import atomic_path
from tankcd_cli.io.exit_guard import guard_termination, tracked
signal.signal(signal.SIGTERM, lambda *a: sys.exit(99))  # Python's handler: never runs below
folder = sys.argv[1]
with atomic_path(os.path.join(folder, "early.h5"), ".h5") as early:
    assert guard_termination() and tracked() == [early]  # one pending before the guard: registered
assert tracked() == []  # renamed onto its target: no longer the guard's
with atomic_path(os.path.join(folder, "late.h5"), ".h5") as late:
    assert tracked() == [late]
    print("READY", flush=True)
    np.convolve(np.ones(400_000), np.ones(100_000))  # seconds in C: Python's handler waits
"""


def test_the_forced_exit_removes_the_pending_outputs_and_exits_143(tmp_path):
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT, str(tmp_path)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "READY", proc.stderr.read()
    assert [p for p in os.listdir(tmp_path) if p.startswith(".tankcd-")]
    time.sleep(0.5)  # well inside the convolution (seconds long), past the Python that starts it
    start = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and err.strip() == "tankcd: terminated", err
    assert time.monotonic() - start < 2.5
    assert sorted(os.listdir(tmp_path)) == ["early.h5"]  # the pending one removed, the finished one kept
