"""Numbers as JSON text (against json's own reading and Python's formatting), pieces of motion."""

import io
import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tankcd_cli.report import places


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(-180, 180), st.floats(-90, 90), st.floats(-1e4, 1e4) | st.just(float("nan"))),
                min_size=1, max_size=40), st.integers(1, 7))
def test_chunked_text_reads_back_as_the_rounded_numbers(rows, chunk):
    a = np.array(rows)
    fh = io.StringIO()
    fh.write("[[")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(places, "_CHUNK_ROWS", chunk)
        places.write_numbers(fh, a, [8, 8, 3], row_sep="],[")
    fh.write("]]")
    back = json.loads(fh.getvalue())
    assert len(back) == len(a)
    for got, want in zip(back, a.tolist()):
        assert abs(got[0] - want[0]) <= 0.5e-8 + 1e-12 and abs(got[1] - want[1]) <= 0.5e-8 + 1e-12
        assert got[2] is None if want[2] != want[2] else abs(got[2] - want[2]) <= 0.5e-3 + 1e-9


def test_pieces_split_only_at_gaps_longer_than_30s():
    t = np.array([0, 1, 31, 61.5, 62, np.nan, 63, 200])
    assert places.pieces(t) == [(0, 3), (3, 7), (7, 8)]
    assert places.pieces(np.array([])) == []


def test_json_text_has_no_nan():
    assert json.loads(places.json_text({"a": float("nan"), "b": np.float32(1.5), "c": np.array([1, np.inf])})) == \
        {"a": None, "b": 1.5, "c": [1.0, None]}
