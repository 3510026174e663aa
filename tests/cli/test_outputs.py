"""Where a command's outputs go: pipes, devices and open files written in place (never replaced by a
regular file), and every output of a command committed together or none."""

import errno
import os
import stat
import subprocess
import sys

import numpy as np
import pytest

from tests.conftest import PipeReader, write_asc

ROWS = 300


@pytest.fixture(scope="module")
def ground(tmp_path_factory):
    from click.testing import CliRunner

    from tankcd_cli.cli.main import cli

    folder = tmp_path_factory.mktemp("outputs")
    ys, xs = np.mgrid[0:80, 0:80] * 1.0
    write_asc(folder / "g.asc", 100 + np.sin(xs / 9) * np.cos(ys / 7), xll=500_000.0, yll=4_500_000.0)
    assert CliRunner().invoke(cli, ["-q", "classify", str(folder / "g.asc"), "-o", str(folder / "g.h5")]).exit_code == 0
    k = np.arange(ROWS)
    with open(folder / "traj.csv", "w") as fh:  # east along a line, heading east
        fh.write("t,x,y,yaw_deg\n" + "".join(f"{i * 0.1:.1f},{500_020 + i * 0.1:.2f},4500040,0\n" for i in k))
    with open(folder / "off.csv", "w") as fh:  # east and off the ground's edge (x = 500,079): events
        fh.write("t,x,y,yaw_deg\n" + "".join(f"{i * 0.1:.1f},{500_060 + i * 0.5:.2f},4500040,0\n" for i in k[:80]))
    return folder


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(".tankcd-"))


def _replay(run, ground, *args):
    return run("-q", "replay", ground / "traj.csv", "--terrain", ground / "g.h5", *args)


@pytest.mark.skipif(os.geteuid() != 0, reason="making a device node needs root")
def test_poses_to_a_character_device_leave_it_a_device(run, ground, tmp_path):
    dev = tmp_path / "null"
    os.mknod(dev, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # the null device's numbers, in our own folder
    res = _replay(run, ground, "--poses", dev, "--events", dev.with_name("ev.jsonl"), "--summary", dev)
    assert res.exit_code == 0, res.stderr
    st = os.stat(dev)
    assert stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 3)
    assert _leftovers(tmp_path) == []


def test_poses_to_a_named_pipe_reach_its_reader(run, ground, tmp_path):
    fifo = tmp_path / "poses.fifo"
    os.mkfifo(fifo)
    reader = PipeReader(path=fifo)
    reader.start()
    res = _replay(run, ground, "--poses", fifo, "--events", tmp_path / "ev.jsonl")
    reader.join(30)
    assert res.exit_code == 0, res.stderr
    lines = reader.data.decode().splitlines()
    assert lines[0].startswith("step,t,x") and len(lines) == ROWS + 1
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and (tmp_path / "ev.jsonl").exists()


def test_parquet_poses_to_a_named_pipe_are_a_whole_parquet_file(run, ground, tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    fifo = tmp_path / "poses.parquet"  # a pipe whose name asks for Parquet: built whole, then copied in
    os.mkfifo(fifo)
    reader = PipeReader(path=fifo)
    reader.start()
    res = _replay(run, ground, "--poses", fifo)
    reader.join(30)
    assert res.exit_code == 0, res.stderr
    assert pq.read_table(pa.BufferReader(reader.data)).num_rows == ROWS
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_poses_to_a_process_substitution(run, ground, tmp_path):
    """`--poses >(gzip > p.gz)`: the shell passes /dev/fd/N, a pipe's write end."""
    r, w = os.pipe()
    reader = PipeReader(fd=r)
    reader.start()
    try:
        res = _replay(run, ground, "--poses", f"/dev/fd/{w}")
    finally:
        os.close(w)
    reader.join(30)
    assert res.exit_code == 0, res.stderr
    assert len(reader.data.decode().splitlines()) == ROWS + 1


def test_poses_to_dev_stdout(ground):
    proc = subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "replay", ground / "traj.csv", "--terrain",
                           ground / "g.h5", "--poses", "/dev/stdout"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert len(proc.stdout.splitlines()) == ROWS + 1


def test_the_same_pipe_for_two_outputs_is_refused(run, ground, tmp_path):
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    res = _replay(run, ground, "--poses", fifo, "--events", fifo)
    assert res.exit_code == 2 and "--events" in res.stderr and "--poses" in res.stderr


def test_a_summary_into_a_missing_folder_leaves_no_poses_nor_events(run, ground, tmp_path):
    poses, events = tmp_path / "p.csv", tmp_path / "e.jsonl"
    res = _replay(run, ground, "--poses", poses, "--events", events, "--summary", tmp_path / "missing" / "s.json")
    assert res.exit_code == 3 and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert "missing/s.json" in res.stderr and "output directory does not exist" in res.stderr
    assert not poses.exists() and not events.exists() and _leftovers(tmp_path) == []


def test_a_full_disk_under_the_picture_leaves_no_poses_nor_events(run, ground, tmp_path, monkeypatch):
    from tankcd_cli.replay.drawing import ReplayDrawing

    def full(self, path, *a, **k):
        with open(path, "wb") as fh:
            fh.write(b"\x89PNG")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(ReplayDrawing, "save", full)
    poses, events, summary, png = (tmp_path / n for n in ("p.csv", "e.jsonl", "s.json", "map.png"))
    res = _replay(run, ground, "--poses", poses, "--events", events, "--summary", summary, "--png", png)
    assert res.exit_code == 3, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and "map.png" in res.stderr and "No space left" in res.stderr
    assert not any(p.exists() for p in (poses, events, summary, png)) and _leftovers(tmp_path) == []


def test_every_output_is_committed_on_success(run, ground, tmp_path):
    poses, events, summary = tmp_path / "p.csv", tmp_path / "e.jsonl", tmp_path / "s.json"
    res = _replay(run, ground, "--poses", poses, "--events", events, "--summary", summary)
    assert res.exit_code == 0, res.stderr
    assert poses.exists() and events.exists() and summary.exists() and _leftovers(tmp_path) == []


@pytest.mark.parametrize("failing", ["p.csv", "e.jsonl"])
def test_a_full_disk_names_the_file_being_written(run, ground, tmp_path, monkeypatch, failing):
    import tankcd_cli.io.atomic as atomic

    real = atomic._open_text

    from tests.conftest import FullDisk as Full

    suffix = ".csv.part" if failing.endswith(".csv") else ".jsonl.part"
    monkeypatch.setattr(atomic, "_open_text", lambda path, newline: Full(real(path, newline))
                        if path.endswith(suffix) else real(path, newline))
    # a path off the ground's edge: off_terrain events are written too
    res = run("-q", "replay", ground / "off.csv", "--terrain", ground / "g.h5", "--poses", tmp_path / "p.csv",
              "--events", tmp_path / "e.jsonl")
    other = "e.jsonl" if failing == "p.csv" else "p.csv"
    assert res.exit_code == 3, res.stderr
    assert f"{failing}: cannot write output: No space left on device" in res.stderr and other not in res.stderr
    assert not (tmp_path / "p.csv").exists() and not (tmp_path / "e.jsonl").exists()
