"""The compiled CSV chunk parser: edge cases of its fast path, bit for bit float()'s, and the inputs it takes."""

import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.io.csv_columns import numeric_chunks
from tankcd_cli.io.csv_kernels import POW10, parse_table


def _float_table(text):
    return [float(c) for c in text.replace("\r", "").replace("\n", ",").split(",") if c.strip()]


@pytest.mark.parametrize("cell", [
    "0", "-0", "-0.0", "+0e5", "0e999", "0e400", "0.000000000000000000000000000", "1e22", "1e-22", "-9.99999999999999e22",
    "123456789012345", "0.123456789012345", "123456789012345e-22", "1" + "0" * 14 + "e7", "0" * 300 + "1.5",
    "500123.4567", "-4500987.123456", "5e-324e", ".5", "5.", "1E+05", "2e-0", "\t7 "])
def test_fast_path_cells_are_float_bits(cell):
    values, ok = parse_table(np.frombuffer(f"{cell},1\n".encode(), np.uint8), 1, 2, POW10)
    if ok:
        expect = np.array(_float_table(f"{cell},1"))
        assert values.ravel().view(np.uint64).tolist() == expect.view(np.uint64).tolist()
    else:
        assert cell in ("5e-324e", "0e999")  # a stray letter; an exponent past 400 even on a zero


@pytest.mark.parametrize("cell", ["1e23", "1e-23", "1234567890123456", "9" * 40, "1e401", "nan", "inf", "1e", "+", ""])
def test_off_the_fast_path_is_not_ok(cell):
    assert parse_table(np.frombuffer(f"{cell},1\n".encode(), np.uint8), 1, 2, POW10)[1] is False


def test_inputs_it_takes():
    text = b"1.5,2\n-3,4e2\n"
    base, ok = parse_table(np.frombuffer(text, np.uint8), 2, 2, POW10)
    assert ok is True and base.shape == (2, 2) and base.dtype == np.float64
    padded = np.zeros(2 * len(text), np.uint8)
    padded[::2] = np.frombuffer(text, np.uint8)
    for buf in (padded[::2], np.frombuffer(text, np.int8), list(text)):  # strided, another dtype, a list
        values, ok = parse_table(buf, 2, 2, list(POW10))
        assert ok is True and np.array_equal(values, base)
    values, ok = parse_table(np.zeros(0, np.uint8), 0, 3, POW10)
    assert ok is True and values.shape == (0, 3)
    assert parse_table(np.zeros(0, np.uint8), 1, 3, POW10)[1] is False


# -- the trajectory kernels: the interner, each entity's order, the carry ------------------------------------------
def test_the_interner_codes_in_order_of_first_appearance_across_calls_and_growth():
    from tankcd_cli.io.csv_kernels import Interner

    rng = np.random.default_rng(3)
    words = [f"id{k}".encode() for k in range(5000)] + [b"", b"\xc3\x9c", b"a" * 300]
    interner, seen = Interner(), {}
    for _ in range(6):
        pick = [words[int(k)] for k in rng.integers(0, len(words), 3000)]
        buf = np.frombuffer(b"".join(pick), np.uint8)
        ends = np.cumsum([len(w) for w in pick])
        span = np.column_stack([ends - [len(w) for w in pick], ends]).astype(np.int64)
        codes, first, first_rows = interner.codes(buf, span, len(pick))
        assert first == len(seen)
        want = [seen.setdefault(w, len(seen)) for w in pick]
        assert codes.tolist() == want and len(interner) == len(seen)
        new = sorted(set(want) - set(range(first)))
        assert [want[r] for r in first_rows.tolist()] == new  # each new code's first row
    assert [interner.name(k) for k in range(len(seen))] == list(seen)
    with pytest.raises(IndexError):
        interner.name(len(seen))


def test_entity_order_and_carry():
    from tankcd_cli.io.csv_kernels import carry, entity_order

    codes = np.array([0, 1, 0, 2, 1, 0], np.int64)
    t = np.array([1.0, 5.0, 1.0, 0.0, 4.0, 2.0])
    last_t, last_line, seen = np.full(3, np.nan), np.zeros(3, np.int64), np.zeros(3, np.uint8)
    piece = np.zeros(6, np.uint8)
    bad = entity_order(codes, t, np.arange(10, 16, dtype=np.int64), last_t, last_line, seen, piece)
    assert bad == 4 and piece[:4].tolist() == [1, 1, 0, 1]
    assert last_t.tolist() == [1.0, 5.0, 0.0] and last_line.tolist() == [12, 11, 13]
    v = np.array([np.nan, 2.0, np.nan, np.nan, np.nan, 3.0])
    last = np.array([7.0, 0.0, 0.0])
    carry(codes, v, last)
    assert v.tolist() == [7.0, 2.0, 7.0, 0.0, 2.0, 3.0] and last.tolist() == [3.0, 2.0, 0.0]


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
