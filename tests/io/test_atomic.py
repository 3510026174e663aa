"""Atomic outputs: a target appears whole or not at all, and outputs committed together appear
together or not at all."""

import os

import pytest

from tankcd_cli.io import atomic
from tankcd_cli.io.atomic import atomic_path, committed_together, output_text


def _leftovers(folder):
    return sorted(p for p in os.listdir(folder) if p.startswith(".tankcd-"))


def test_outputs_committed_together_appear_only_when_the_block_completes(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.jsonl"
    with committed_together():
        with output_text(str(a), ".csv") as fa, output_text(str(b), ".jsonl") as fb:
            fa.write("x\n")
            fb.write("{}\n")
        assert not a.exists() and not b.exists()  # both complete, neither renamed yet
    assert a.read_text() == "x\n" and b.read_text() == "{}\n"
    assert _leftovers(tmp_path) == [] and not atomic._PENDING


@pytest.mark.parametrize("where", ["inside", "after"])
def test_a_failure_in_the_block_leaves_neither(tmp_path, where):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text("old\n")
    with pytest.raises(KeyboardInterrupt):
        with committed_together():
            with atomic_path(str(a), ".csv") as ta, atomic_path(str(b), ".csv") as tb:
                open(ta, "w").write("new\n")
                open(tb, "w").write("new\n")
                if where == "inside":
                    raise KeyboardInterrupt
            raise KeyboardInterrupt  # both outputs complete: the block has not
    assert a.read_text() == "old\n" and not b.exists()
    assert _leftovers(tmp_path) == [] and not atomic._PENDING


def test_pending_temporaries_are_removed_at_exit(tmp_path):
    """What a signal cut short of its clean-up (the writer's finally never ran) goes at exit."""
    gen = atomic_path(str(tmp_path / "a.csv"), ".csv")
    tmp = gen.__enter__()  # left open, as a writer is when a signal lands inside contextlib's exit
    assert os.path.exists(tmp) and tmp in atomic._PENDING
    atomic.remove_pending()
    assert not os.path.exists(tmp) and not atomic._PENDING


# -- outputs written in place: pipes, devices, open files -------------------------------------------------

import stat

from tests.conftest import PipeReader

root_only = pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0,
                               reason="making a device node needs root")


def _null_device(folder):
    """A character device of our own with the null device's numbers (1, 3): never /dev/null itself."""
    path = folder / "null"
    os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    return path


@root_only
@pytest.mark.parametrize("binary", [False, True])
def test_a_character_device_is_written_in_place_never_replaced(tmp_path, binary):
    dev = _null_device(tmp_path)
    before = os.stat(dev)
    if binary:
        with atomic_path(str(dev), ".h5") as tmp:
            open(tmp, "wb").write(b"\x89HDF" * 1000)
    else:
        with output_text(str(dev), ".csv") as fh:
            fh.write("x\n" * 1000)
    after = os.stat(dev)
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == os.makedev(1, 3) and after.st_ino == before.st_ino
    assert _leftovers(tmp_path) == [] and not atomic._PENDING


def test_a_block_device_is_refused(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    disk = tmp_path / "disk"
    os.mknod(disk, stat.S_IFBLK | 0o600, os.makedev(7, 200))  # a loop device's numbers: never opened
    from tankcd_cli.errors import InputError

    with pytest.raises(InputError, match="block device"):
        with output_text(str(disk), ".csv") as fh:
            fh.write("x\n")
    assert stat.S_ISBLK(os.stat(disk).st_mode)


@pytest.mark.parametrize("binary", [False, True])
def test_a_named_pipe_is_written_in_place_and_its_reader_gets_everything(tmp_path, binary):
    fifo = tmp_path / "poses.fifo"
    os.mkfifo(fifo)
    reader = PipeReader(path=fifo)
    reader.start()
    text = "".join(f"{k},{k * 0.1:.1f}\n" for k in range(20_000))  # more than a pipe's buffer
    with committed_together():
        if binary:
            with atomic_path(str(fifo), ".parquet") as tmp:
                open(tmp, "w").write(text)
        else:
            with output_text(str(fifo), ".csv") as fh:
                fh.write(text)
    reader.join(10)
    assert reader.data.decode() == text
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert _leftovers(tmp_path) == [] and not atomic._PENDING


@pytest.mark.parametrize("binary", [False, True])
def test_a_process_substitution_path_is_written_in_place(tmp_path, binary):
    """`--poses >(gzip > p.gz)` names the pipe's write end as /dev/fd/N."""
    r, w = os.pipe()
    reader = PipeReader(fd=r)
    reader.start()
    target = f"/dev/fd/{w}"
    assert atomic.writes_in_place(target)
    try:
        if binary:
            with atomic_path(target, ".png") as tmp:
                open(tmp, "wb").write(b"\x89PNG" * 5000)
        else:
            with output_text(target, ".csv") as fh:
                fh.write("a,b\n" * 5000)
    finally:
        os.close(w)
    reader.join(10)
    assert reader.data == (b"\x89PNG" * 5000 if binary else b"a,b\n" * 5000)


def test_regular_files_and_new_names_are_still_renamed_onto(tmp_path):
    target = tmp_path / "p.csv"
    assert not atomic.writes_in_place(str(target))
    target.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    assert not atomic.writes_in_place(str(link))  # a link to a regular file: the file is replaced
    with output_text(str(link), ".csv") as fh:
        fh.write("new\n")
    assert target.read_text() == "new\n" and link.is_symlink()


# -- each writer's error names its own file -----------------------------------------------------------------


def test_a_full_disk_under_one_of_two_outputs_names_that_one(tmp_path, monkeypatch):
    from tankcd_cli.errors import InputError
    from tests.conftest import FullDisk as Full

    real = atomic._open_text

    def open_text(path, newline):
        fh = real(path, newline)
        return Full(fh) if path.endswith(".csv.part") else fh
    monkeypatch.setattr(atomic, "_open_text", open_text)
    poses, events = tmp_path / "poses.csv", tmp_path / "events.jsonl"
    with pytest.raises(InputError) as err:
        # the events opened last, inside which the poses are written (as a replay's outputs are)
        with committed_together(), output_text(str(poses), ".csv") as fp, output_text(str(events), ".jsonl") as fe:
            fe.write("{}\n")
            fp.write("x\n")
    assert str(poses) in str(err.value) and str(events) not in str(err.value)
    assert "No space left on device" in str(err.value)
    assert not poses.exists() and not events.exists() and _leftovers(tmp_path) == []


# -- parts a killed run left --------------------------------------------------------------------------------


def _dead_pid():
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_a_dead_runs_parts_are_cleared_by_the_next_write_in_that_folder(tmp_path, monkeypatch):
    monkeypatch.setattr(atomic, "_CLEARED", set())
    host = atomic._host_tag()
    dead = tmp_path / f".tankcd-{host}-{_dead_pid()}-0123456789ab.csv.part"
    alive = tmp_path / f".tankcd-{host}-{os.getppid()}-0123456789ab.csv.part"  # a live process's
    other_host = tmp_path / f".tankcd-{host}x-{_dead_pid()}-0123456789ab.csv.part"  # another machine's
    older = tmp_path / ".tankcd-0123456789ab.csv.part"  # an older tankcd's (no pid): unknown
    for p in (dead, alive, other_host, older):
        p.write_text("cut short\n")
    assert atomic.part_owner(dead.name) == (host, int(dead.name.split("-")[2]))
    with output_text(str(tmp_path / "p.csv"), ".csv") as fh:
        fh.write("x\n")
    assert not dead.exists() and alive.exists() and other_host.exists() and older.exists()
    assert (tmp_path / "p.csv").read_text() == "x\n"


def test_a_part_names_its_host_and_pid(tmp_path):
    with atomic_path(str(tmp_path / "a.h5"), ".h5") as tmp:
        assert atomic.part_owner(os.path.basename(tmp)) == (atomic._host_tag(), os.getpid())


def test_nested_blocks_commit_with_the_outermost(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "s.json"
    with pytest.raises(KeyboardInterrupt):
        with committed_together():
            with committed_together(), output_text(str(a), ".csv") as fh:
                fh.write("x\n")
            assert not a.exists()  # the inner block is done: its output waits for the outer
            with output_text(str(b), ".json") as fh:
                fh.write("{}\n")
            raise KeyboardInterrupt
    assert not a.exists() and not b.exists() and _leftovers(tmp_path) == [] and not atomic._PENDING
