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
