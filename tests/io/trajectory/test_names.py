"""The entity-id rule, once (tankcd_cli.io.trajectory.names): the CSV reader (its compiled pass and its
careful reader), the arrays of api.trajectory_chunks, GPX track names and file stems all hold to it."""

import numpy as np
import pytest

from tankcd_cli import api
from tankcd_cli.errors import InputError
from tankcd_cli.io.trajectory import read_trajectory
from tankcd_cli.io.trajectory.gpx_input import track_names
from tankcd_cli.io.trajectory.names import entity_id_fault, entity_id_from, stem_name


def test_the_rule():
    assert entity_id_fault("tank 1") is None and entity_id_fault("Т-72 №4") is None
    assert [entity_id_fault(t) for t in ("", "a\"b", "a'b", "a,b", "a\tb", "a\nb", "a\x7fb", "a',b")] == \
        ["empty", "quote", "quote", "comma", "control", "control", "control", "quote"]
    assert entity_id_from("a,b'c\"d\te\x7f") == "a_b_c_d_e_"
    assert stem_name("/x/run,1.csv.gz") == "run_1" and stem_name("-") == "stdin"
    assert track_names(["a,b", "a,b", "", " "]) == ["a_b", "a_b_2", "track3", "track4"]


@pytest.mark.parametrize("code", range(1, 128))
def test_the_csv_reader_and_the_arrays_take_an_id_exactly_when_the_rule_does(tmp_path, code):
    # every ASCII character inside an id (blanks around it are taken off by both, as the rule says)
    ch = chr(code)
    if ch in "\n\r":
        return  # a line break ends the CSV's row: no id holds one there
    name = f"a{ch}b"
    good = entity_id_fault(name) is None
    path = tmp_path / "t.csv"
    path.write_bytes(f"t,entity,x,y,yaw_deg\n0,{name},0,0,0\n".encode())
    try:
        chunks = list(read_trajectory(str(path)))
        took = chunks[0].entity_names == (name,)
    except InputError:
        took = False
    if ch == ",":  # one cell more than the header: refused for its cell count
        assert not good and not took
        return
    assert took == good, repr(ch)
    arrays = {"t": [0.0], "x": [0.0], "y": [0.0], "yaw_deg": [0.0], "entity": np.array([name], dtype=object)}
    try:
        took = list(api.trajectory_chunks(arrays))[0].entity_names == (name,)
    except InputError:
        took = False
    assert took == good, repr(ch)
