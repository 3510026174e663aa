"""Fuzzing the readers: valid files of every format, mutated at random, through the commands.

Whatever the bytes, a command ends with exit 0 (the mutation left a valid file), 1 (a
collision with --fail-on-collision: not used here) or 3 with one line naming the file;
never an internal error (exit 4) and never a traceback. Bounded in CI; run longer by hand:

    TANKCD_FUZZ_EXAMPLES=3000 python -m pytest tests/cli/test_fuzz.py -q

Every crash found becomes a regression test in test_malformed.py or below.
"""

import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.hard_cases import inputs

EXAMPLES = int(os.environ.get("TANKCD_FUZZ_EXAMPLES", "40"))
SPECIALS = [b"nan", b"inf", b"-inf", b"1e309", b"-0", b"", b"9" * 40, b"1e-400", b"0x10", b"\x00", b"\xff\xfe",
            b"\r", b"\n", b",", b" ", b"\"", b"[", b"=", b"-1", b"0"]


@st.composite
def mutated(draw, data: bytes):
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["truncate", "flip", "insert", "delete", "duplicate_line", "special"]))
        p = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "truncate":
            data = data[:p]
        elif kind == "flip":
            data = data[:p] + bytes([draw(st.integers(0, 255))]) + data[p + 1:]
        elif kind == "insert":
            data = data[:p] + draw(st.binary(min_size=1, max_size=8)) + data[p:]
        elif kind == "delete":
            data = data[:p] + data[p + draw(st.integers(1, 40)):]
        elif kind == "duplicate_line":
            lines = data.splitlines(keepends=True)
            if lines:
                k = draw(st.integers(0, len(lines) - 1))
                lines.insert(k, lines[k])
                data = b"".join(lines)
        else:  # a special token over a number
            end = p
            while end < len(data) and data[end:end + 1] not in b" ,\n\r\t":
                end += 1
            data = data[:p] + draw(st.sampled_from(SPECIALS)) + data[end:]
    return data


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    from click.testing import CliRunner

    from tankcd_cli.cli.main import cli

    tmp = tmp_path_factory.mktemp("fuzz")

    def run(*args):
        return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
    return tmp, run, inputs.setup(tmp, run)


def _fuzz(world, fmt, suffix, data):
    tmp, run, paths = world
    bad = tmp / f"fuzzed{suffix}"
    bad.write_bytes(data)
    out = tmp / "fuzz-out"
    if out.exists():
        out.unlink()
    res = run(*inputs.command(fmt, bad, paths, out))
    assert res.exit_code in (0, 3), (res.exit_code, res.stderr, data[:200])
    assert "Traceback" not in res.stderr
    if res.exit_code == 3:
        # one error line (set-up warnings about rows read before the bad one may precede it)
        lines = [ln for ln in res.stderr.strip().splitlines() if not ln.startswith("tankcd: warning:")]
        assert len(lines) == 1 and "fuzzed" in lines[0], (res.stderr, data[:200])
        assert not out.exists()


FORMATS = {"asc": ".asc", "obj": ".obj", "trajectory": ".csv", "poses": ".csv", "scene": ".toml",
           "store": ".h5", "tree": ".h5"}


@pytest.mark.parametrize("fmt", FORMATS)
def test_fuzz_reader(fmt, world):
    _, _, paths = world
    source = paths["scene"] if fmt == "scene" else paths[fmt]
    seed = source.read_bytes()
    # HDF5 files are mostly structure: fewer examples, each costs a full open
    n = EXAMPLES if fmt not in ("store", "tree") else max(EXAMPLES // 4, 5)

    @settings(max_examples=n, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                     HealthCheck.data_too_large])
    @given(mutated(seed))
    def check(data):
        runs.append(len(data))
        _fuzz(world, fmt, FORMATS[fmt], data)
    runs = []
    check()
    print(f"fuzzed {fmt}: {len(runs)} executions")
    assert len(runs) >= n  # the harness really ran (hypothesis stops early only on a failure)
