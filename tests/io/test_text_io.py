"""The fast CSV paths (one C parse per chunk; compiled fixed-point writer) against plain Python."""

import io
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.errors import InputError
from tankcd_cli.io.csv_columns import numeric_chunks
from tankcd_cli.io.poses_csv import format_rows, format_rows_printf
from tankcd_cli.matching.match import PLACED_BY, STATUS

finite = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e12, max_value=1e12)
style = st.sampled_from(["{!r}", "{:.3f}", "{:.6e}", " {!r} ", "{:+.2f}"])


def _read(text, chunk_rows=7):
    out = []
    for rows, wanted, values in numeric_chunks(io.StringIO(text, newline=""), "t.csv", ("a", "b"), ("c",), chunk_rows):
        out.append((rows, wanted, values))
    return out


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(finite, finite, finite), min_size=1, max_size=40), style, st.sampled_from(["\n", "\r\n"]),
       st.permutations(["a", "b", "c", "extra"]))
def test_numbers_read_as_python_reads_them(rows, fmt, newline, order):
    lines = [",".join(order)]
    for a, b, c in rows:
        cell = {"a": a, "b": b, "c": c, "extra": 1.0}
        lines.append(",".join(fmt.format(cell[k]) for k in order))
    text = newline.join(lines) + newline
    got = _read(text)
    values = np.concatenate([v for _, _, v in got])
    lineno = [r for r, _, _ in got for r in r]
    expect = [[float(fmt.format(v)) for v in row] for row in rows]
    assert got[0][1] == ["a", "b", "c"]
    np.testing.assert_array_equal(values, np.array(expect))
    assert lineno == list(range(2, 2 + len(rows)))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 30), st.data(), st.sampled_from(["x", "", "nan", "inf", "1,2", "1 2", "0x1p3", "1.5.2", "\x00"]))
def test_a_bad_cell_is_named_and_the_rows_before_it_kept(n, data, bad):
    k = data.draw(st.integers(0, n - 1))
    col = data.draw(st.sampled_from(["a", "b", "c"]))
    lines = ["a,b,c"] + [f"{i},{i + 0.5},{-i}" for i in range(n)]
    cells = lines[k + 1].split(",")
    cells["abc".index(col)] = bad
    lines[k + 1] = ",".join(cells)
    delivered = []
    with pytest.raises(InputError) as err:
        for rows, _, values in numeric_chunks(io.StringIO("\n".join(lines) + "\n", newline=""), "t.csv",
                                              ("a", "b"), ("c",), 7):
            delivered.extend(values[:, 0].tolist())
    assert f"line {k + 2}" in str(err.value)
    if bad != "1,2":  # a wrong cell count is a row's fault, not a column's
        assert f"column {col}" in str(err.value)
    assert delivered == [float(i) for i in range(k)]


def _poses(rng, n):
    return SimpleNamespace(
        position=np.column_stack([5e5 + rng.uniform(0, 500, n), 4.5e6 + rng.uniform(0, 500, n), rng.normal(0, 300, n)]),
        roll=rng.normal(0, 0.3, n), pitch=rng.normal(0, 0.3, n), yaw=rng.uniform(-np.pi, np.pi, n),
        quaternion=rng.normal(0, 0.5, (n, 4)), penetration=np.abs(rng.normal(0, 0.01, n)), gap=rng.exponential(0.1, n),
        region=rng.choice([0, 1, 2, 255], n).astype(np.uint8), matcher=rng.integers(0, len(PLACED_BY), n),
        status=rng.integers(0, len(STATUS), n))


def _cells(text):
    return [line.split(",") for line in text.splitlines()]


@pytest.mark.parametrize("seed", range(5))
def test_compiled_pose_rows_match_printf(seed):
    rng = np.random.default_rng(seed)
    n = 3000
    p = _poses(rng, n)
    p.position[rng.integers(0, n, 20), 2] = np.nan  # no pose: only t, x, y, yaw are written
    p.gap[rng.integers(0, n, 20)] = np.nan  # no measure: penetration and gap both empty
    p.roll[:50] = rng.choice([0.0, -0.0, -1e-12, 1e-12], 50)
    step = np.arange(n) + 10 ** 7
    t = step * 0.1
    fast, slow = _cells(format_rows(step, t, p, PLACED_BY, STATUS)), _cells(format_rows_printf(step, t, p, PLACED_BY, STATUS))
    assert len(fast) == len(slow) == n
    decimals = [0, 6, 4, 4, 4, 5, 5, 5, 8, 8, 8, 8, None, None, 4, 4, None]
    for a, b in zip(fast, slow):
        assert len(a) == len(b) == 17
        for x, y, d in zip(a, b, decimals):
            if d is None or x == "" or y == "":
                assert x == y
            else:  # same value to the last digit; printf may write -0.000 where we write 0.000
                assert x == y or abs(float(x) - float(y)) <= 10.0 ** -d * 1.0001, (x, y)


def test_values_too_large_for_fixed_point_use_printf():
    rng = np.random.default_rng(1)
    p = _poses(rng, 10)
    p.position[3, 2] = 1e15
    text = format_rows(np.arange(10), np.arange(10.0), p, PLACED_BY, STATUS)
    assert text == format_rows_printf(np.arange(10), np.arange(10.0), p, PLACED_BY, STATUS)


plain = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e7, max_value=1e7)
written = st.sampled_from(["{:.3f}", "{:.6f}", "{!r}", "{:.4e}", "{:+.1f}", " {:.2f}", "{:.10g}", "{:.0f}", "{:.15g}",
                           "{:.17g}", "{:.3E}"])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(plain, plain, plain), min_size=1, max_size=30), written, st.sampled_from(["\n", "\r\n"]),
       st.booleans())
def test_compiled_parser_gives_what_float_gives(rows, fmt, newline, final_newline):
    """Bit for bit: the compiled parser's fast path or its fall-back, never a nearby double."""
    from tankcd_cli.io.csv_kernels import POW10, parse_table

    cells = [[fmt.format(v) for v in row] for row in rows]
    text = newline.join(",".join(row) for row in cells) + (newline if final_newline else "")
    values, ok = parse_table(np.frombuffer(text.encode(), np.uint8), len(rows), 3, POW10)
    expect = np.array([[float(c) for c in row] for row in cells])
    if ok:
        assert np.array_equal(values, expect) and np.array_equal(np.signbit(values), np.signbit(expect))
    # whichever path read it, the reader's answer is float()'s
    got = np.concatenate([v for _, _, v in numeric_chunks(io.StringIO("a,b,c\n" + text, newline=""), "t.csv",
                                                          ("a", "b", "c"), (), 7)])
    assert np.array_equal(got, expect)


@pytest.mark.parametrize("text, ok", [
    ("1,2,3\n4,5,6\n", True), ("1,2,3\n4,5,6", True), ("1,2,3\r\n4,5,6\r\n", True), (" 1 , 2 ,3\n", True),
    (".5,5.,-0\n", True), ("1e5,2E-3,+4\n", True), ("1,2\n", False), ("1,2,3,4\n", False), ("1,,3\n", False),
    ("nan,2,3\n", False), ("1,2,3\n\n", False), ("1_0,2,3\n", False), ("0x1,2,3\n", False),
    ("1234567890123456,1,2\n", False), ("1e400,1,2\n", False), ("1e,2,3\n", False), ("-,2,3\n", False),
    ("1.2.3,4,5\n", False), ("1,2,3\r4,5,6\n", False)])
def test_compiled_parser_shapes(text, ok):
    from tankcd_cli.io.csv_kernels import POW10, parse_table

    rows = len(text.splitlines())
    values, good = parse_table(np.frombuffer(text.encode(), np.uint8), rows, 3, POW10)
    assert good is ok
    if ok:
        assert np.array_equal(values.ravel(), [float(c) for c in text.replace("\r", "").replace("\n", ",").split(",")
                                               if c.strip()])
