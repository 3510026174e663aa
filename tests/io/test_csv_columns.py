"""Numeric CSV columns by header name: the chunk reader against plain Python, every bad cell named by
line and column, the header's rules."""

import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.errors import InputError
from tankcd_cli.io.csv_columns import numeric_chunks

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


def _chunks(text, required=("a", "b"), optional=("c",), chunk_rows=7, **kw):
    return list(numeric_chunks(io.StringIO(text, newline=""), "t.csv", required, optional, chunk_rows, **kw))


def test_the_header_names_columns_in_any_order_quoted_or_spaced_and_extras_are_ignored():
    text = 'extra, "b" ,c,a\nx,2,3,1\ny,5,6,4\n'
    (rows, wanted, values), = _chunks(text)
    assert rows == [2, 3] and wanted == ["a", "b", "c"]
    np.testing.assert_array_equal(values, [[1, 2, 3], [4, 5, 6]])
    (_, wanted, values), = _chunks("b,a\n2,1\n")  # an optional column absent: not delivered
    assert wanted == ["a", "b"] and values.tolist() == [[1.0, 2.0]]


def test_chunks_hold_chunk_rows_lines_numbered_from_the_file():
    text = "a,b\n" + "".join(f"{i},{-i}\n" for i in range(10))
    got = _chunks(text, chunk_rows=4)
    assert [r for r, _, _ in got] == [[2, 3, 4, 5], [6, 7, 8, 9], [10, 11]]
    np.testing.assert_array_equal(np.concatenate([v for _, _, v in got])[:, 0], np.arange(10))
    # a part of a file read after its header: lines count from line_offset
    got = _chunks("a,b\n1,2\n3,4\n", line_offset=40)
    assert got[0][0] == [41, 42]
    with pytest.raises(InputError, match="line 42 column b"):
        _chunks("a,b\n1,2\n3,x\n", line_offset=40)


def test_blank_lines_are_skipped_and_blank_cells_are_nan_where_allowed():
    text = "\n\na,b,c\n1,2,\n\n4,,6\n"
    (rows, _, values), = _chunks(text, blank_ok=("b", "c"))
    assert rows == [4, 6]  # the header on line 3, a blank line between the rows
    np.testing.assert_array_equal(values, [[1, 2, np.nan], [4, np.nan, 6]])
    with pytest.raises(InputError, match="line 6 column b") as err:
        _chunks(text, blank_ok=("c",))
    assert err.value.args  # one error, for the first bad cell


@pytest.mark.parametrize("text, message, where", [
    ("", "file is empty (a header row with a,b is needed)", None),
    ("\n\n", "file is empty", None),
    ("a\x00b\n1\n", "not a text file", "line 1"),
    ("a,c\n1,2\n", "header lacks the required column b (found: a, c)", "line 1"),
    ("c\n1\n", "header lacks the required columns a, b", "line 1"),
    ("\na,b,a\n1,2,3\n", "column a appears twice in the header", "line 2"),
    ("a,b\n1,2\n1,2,3\n", "expected 2 columns as in the header, found 3", "line 3"),
    ("a,b\n1,2\n1\n", "expected 2 columns as in the header, found 1", "line 3"),
    ("a,b\n1,inf\n", "non-finite value 'inf'", "line 2 column b"),
    ("a,b\n1, twelve \n", "not a number: 'twelve'", "line 2 column b"),
])
def test_what_is_refused_and_where(text, message, where):
    with pytest.raises(InputError) as err:
        _chunks(text)
    assert message in str(err.value)
    if where is not None:
        assert where in str(err.value)


def test_an_extra_column_may_repeat_and_the_hint_is_added_to_a_missing_column():
    (_, _, values), = _chunks("a,x,b,x\n1,9,2,9\n")
    assert values.tolist() == [[1.0, 2.0]]
    seen = []

    def hint(header, missing):
        seen.append((header, missing))
        return "try the other file"
    with pytest.raises(InputError, match="lacks the required column b .*; try the other file"):
        _chunks("a,z\n1,2\n", hint=hint)
    assert seen == [(["a", "z"], ["b"])]


@pytest.mark.parametrize("text", ["a,b\n1,2\n3,4\n", "a,b\r\n1,2\r\n3,4\r\n", "a,b\n1,2\n3,4"])
def test_line_endings_and_a_last_line_without_one(text):
    (rows, _, values), = _chunks(text)
    assert rows == [2, 3] and values.tolist() == [[1.0, 2.0], [3.0, 4.0]]


def test_text_beyond_ascii_takes_the_careful_path_with_the_same_answer():
    (_, _, plain), = _chunks("a,b,note\n1,2,x\n4,5,y\n".replace(",x", ",3").replace(",y", ",6"))
    (_, _, wide), = _chunks("a,b,note\n1,2,3\n4,5,6\n".replace("note", "r\u00e9sum\u00e9"))
    assert plain.tolist() == wide.tolist() == [[1.0, 2.0], [4.0, 5.0]]
    with pytest.raises(InputError, match="line 2 column b: not a number: '\u00e9'"):
        _chunks("a,b\n1,\u00e9\n")
