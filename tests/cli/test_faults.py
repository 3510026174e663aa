"""Fault injection: killed runs, failing disks, unwritable places, concurrent runs.

The promise: whatever happens, the target path holds either nothing or a complete output.
"""

import errno
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.conftest import write_asc

ROWS = 400_000


@pytest.fixture(scope="module")
def big(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("faults")
    ys, xs = np.mgrid[0:120, 0:120] * 1.0
    write_asc(tmp / "g.asc", 100 + np.sin(xs / 9) * np.cos(ys / 7), xll=500_000.0, yll=4_500_000.0)
    subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", tmp / "g.asc", "-o", tmp / "g.h5"], check=True)
    k = np.arange(ROWS)
    # round a 40 m circle at 1 m/s, heading the way it goes (a motion no warning is about)
    a = k * 0.01 / 40.0
    traj = np.column_stack([k * 0.01, 500_060 + 40 * np.cos(a), 4_500_060 + 40 * np.sin(a),
                            (np.degrees(a) + 90.0 + 180.0) % 360.0 - 180.0])
    with open(tmp / "traj.csv", "w") as fh:
        fh.write("t,x,y,yaw_deg\n")
        np.savetxt(fh, traj, fmt="%.3f", delimiter=",")
    return tmp


def _tankcd(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "tankcd_cli", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, **kw)


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_a_killed_replay_leaves_nothing_or_everything(big, sig):
    rng = np.random.default_rng(int(sig))
    for delay in rng.uniform(0.3, 2.5, 3):
        out, ev = big / f"poses-{int(sig)}.csv", big / f"events-{int(sig)}.jsonl"
        for p in (out, ev):
            if p.exists():
                p.unlink()
        proc = _tankcd("replay", big / "traj.csv", "--terrain", big / "g.h5", "--poses", out, "--events", ev)
        time.sleep(delay)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
        if out.exists():  # it finished before the signal: then both files are whole (the signal may
            # still have come before the process ended, and set its exit code)
            assert proc.returncode in (0, -int(sig), 130, 143), err
            assert sum(1 for _ in open(out)) == ROWS + 1
            assert ev.exists()
        else:
            assert proc.returncode != 0
            assert not ev.exists()
        if sig != signal.SIGKILL:  # a catchable signal also removes the temporary files
            assert not list(big.glob(".tankcd-*")), list(big.glob(".tankcd-*"))
            if proc.returncode:
                assert proc.returncode in (130, 143), err
    for p in big.glob(".tankcd-*"):  # what SIGKILL leaves: hidden temporaries, never the target
        p.unlink()


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_a_killed_parquet_replay_leaves_nothing_or_everything(big, sig):
    pq = pytest.importorskip("pyarrow.parquet")
    for delay in np.random.default_rng(int(sig)).uniform(0.3, 2.5, 2):
        out, ev = big / f"poses-{int(sig)}.parquet", big / f"events-{int(sig)}.parquet"
        for p in (out, ev):
            if p.exists():
                p.unlink()
        proc = _tankcd("replay", big / "traj.csv", "--terrain", big / "g.h5", "--poses", out, "--events", ev)
        time.sleep(delay)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
        if out.exists():  # finished first: both files whole (a Parquet file cut short has no footer to read)
            assert proc.returncode in (0, -int(sig), 130, 143), err
            assert pq.read_metadata(out).num_rows == ROWS and pq.read_metadata(ev).num_rows >= 0
        else:
            assert proc.returncode != 0 and not ev.exists()
        if sig != signal.SIGKILL:
            assert not list(big.glob(".tankcd-*")), list(big.glob(".tankcd-*"))
    for p in big.glob(".tankcd-*"):
        p.unlink()


def test_a_killed_classify_leaves_nothing(big):
    ys, xs = np.mgrid[0:700, 0:700] * 1.0
    write_asc(big / "large.asc", np.sin(xs / 9) * np.cos(ys / 7))
    for delay in (0.5, 1.0, 1.5):
        target = big / "large.h5"
        proc = _tankcd("classify", big / "large.asc", "-o", target)
        time.sleep(delay)
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=120)
        if proc.returncode == 0:
            assert target.exists()
        if target.exists():
            # the whole store, never a truncated one (a signal just after the rename finds the work done)
            import h5py

            with h5py.File(target) as h5:
                assert h5["classes/grid"].shape == (700, 700) and h5.attrs["layout"] == "grid"
                assert (h5["classes/grid"][()] != 255).all()
            target.unlink()
        assert not list(big.glob(".tankcd-*"))


def test_an_unwritable_place_is_exit_3_and_one_line(big, run):
    # /proc refuses new files even to root (chmod would not stop root)
    res = run("classify", big / "g.asc", "-o", "/proc/tankcd-test.h5")
    assert res.exit_code == 3 and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert "/proc/tankcd-test.h5" in res.stderr


@pytest.mark.parametrize("where", ["mid-stream", "at the rename", "parquet mid-stream", "parquet at the rename"])
def test_a_full_disk_is_exit_3_and_leaves_nothing(big, run, monkeypatch, tmp_path, where):
    import tankcd_cli.io.atomic as atomic
    import tankcd_cli.io.poses_csv as poses_csv

    def full(*a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    suffix = ".parquet" if where.startswith("parquet") else ".csv"
    if where == "parquet mid-stream":  # the disk fills under pyarrow, in the thread writing a row group
        pq = pytest.importorskip("pyarrow.parquet")
        real_write = pq.ParquetWriter.write_table
        written = []

        def write_then_fail(self, *a, **k):
            written.append(1)
            if len(written) > 1:
                full()
            return real_write(self, *a, **k)
        monkeypatch.setattr(pq.ParquetWriter, "write_table", write_then_fail)
    elif where == "mid-stream":
        real = poses_csv.format_rows
        calls = []

        def format_then_fail(*a, **k):
            calls.append(1)
            if len(calls) > 1:
                full()
            return real(*a, **k)
        monkeypatch.setattr(poses_csv, "format_rows", format_then_fail)
    else:
        monkeypatch.setattr(atomic.os, "replace", full)
    out = tmp_path / f"poses{suffix}"
    res = run("replay", big / "traj.csv", "--terrain", big / "g.h5", "--poses", out)
    assert res.exit_code == 3, res.stderr
    assert "No space left on device" in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not out.exists() and not list(tmp_path.glob(".tankcd-*"))


def test_concurrent_runs_from_one_store_do_not_interfere(big):
    head = big / "head.csv"
    with open(big / "traj.csv") as src, open(head, "w") as dst:
        for _ in range(50_001):
            dst.write(src.readline())
    outs = [big / f"c{k}.csv" for k in range(3)]
    procs = [_tankcd("replay", head, "--terrain", big / "g.h5", "--poses", o, "--matcher", m)
             for o, m in zip(outs, ("auto", "auto", "six_point"))]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    alone = big / "alone.csv"
    subprocess.run([sys.executable, "-m", "tankcd_cli", "replay", head, "--terrain", big / "g.h5", "--poses", alone],
                   check=True, capture_output=True)
    assert outs[0].read_bytes() == outs[1].read_bytes() == alone.read_bytes()
    assert outs[2].read_bytes() != alone.read_bytes()  # a different matcher really ran at the same time


# a classify whose tile work starts with a long compiled call (one np.convolve: seconds of C that
# never returns to Python, as a big convolution or warp does), told on stderr when it starts
LONG_CLASSIFY = """
import sys
import numpy as np
import tankcd_cli.terrain.grid.tiled_classify as tiled
real = tiled.classify_tile
def slow(*a, **k):
    sys.stderr.write("LONG\\n"); sys.stderr.flush()
    np.convolve(np.ones(400_000), np.ones(100_000))
    return real(*a, **k)
tiled.classify_tile = slow
from tankcd_cli.cli.main import console
console(sys.argv[1:])
"""


def test_sigterm_in_a_long_compiled_call_ends_the_run_within_a_second(tmp_path):
    pytest.importorskip("tankcd_cli.io._exit_guard")  # the compiled guard (setup.py build_ext)
    ys, xs = np.mgrid[0:60, 0:60] * 1.0
    write_asc(tmp_path / "g.asc", np.sin(xs / 9) * np.cos(ys / 7))
    out = tmp_path / "out"
    out.mkdir()
    target = out / "g.h5"
    proc = subprocess.Popen([sys.executable, "-c", LONG_CLASSIFY, "classify", tmp_path / "g.asc", "-o", target],
                            stderr=subprocess.PIPE, text=True)
    assert proc.stderr.readline().strip() == "LONG"
    assert list(out.glob(".tankcd-*")), "the store's temporary file is there while the run works"
    time.sleep(0.5)  # well inside the convolution (seconds long), past the Python that starts it
    start = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    err = proc.communicate(timeout=60)[1]
    took = time.monotonic() - start
    assert proc.returncode == 143 and "terminated" in err, err
    assert took < 2.5, took  # the 1 s grace and the exit (the convolution alone takes far longer)
    assert not target.exists() and not list(out.glob(".tankcd-*"))
