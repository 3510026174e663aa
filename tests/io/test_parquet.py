"""Parquet outputs: written by tankcd_cli.io.parquet, read back by pyarrow: value for value what was written,
and what the CSV writer prints; metadata; atomic; the events' typed schema."""

import csv
import hashlib
import io
import os
import sys

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io import parquet as P
from tankcd_cli.io.poses_csv import COLUMNS, format_rows
from tankcd_cli.matching.match import Poses
from tankcd_cli.names import PLACED_BY, STATUS

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")


def poses(n, seed=0):
    rng = np.random.default_rng(seed)
    yaw = rng.uniform(-np.pi, np.pi, n)
    roll, pitch = rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    q[q[:, 0] < 0] *= -1
    status = rng.choice([0, 0, 0, 1, 2], n)
    pos = np.column_stack([500_000 + rng.uniform(0, 1000, n), 4_500_000 + rng.uniform(0, 1000, n),
                           rng.uniform(100, 200, n)])
    pen = rng.uniform(0, 0.1, n)
    pen[rng.random(n) < 0.2] = np.nan
    gap = rng.uniform(0, 0.1, n)
    off = status == 2
    for a in (roll, pitch, pen, gap):
        a[off] = np.nan
    pos[off, 2] = np.nan
    q[off] = np.nan
    region = rng.choice([0, 1, 2, 255], n).astype(np.uint8)
    return Poses(position=pos, roll=roll, pitch=pitch, yaw=yaw, quaternion=q, plane=np.zeros((n, 3)), region=region,
                 matcher=rng.integers(0, len(PLACED_BY), n), status=status, penetration=pen, gap=gap,
                 covered=np.ones(n))


def _chunks(n=3000, parts=3):
    p = poses(n)
    step = np.arange(n) * 2
    t = np.arange(n) * 0.1
    bounds = np.linspace(0, n, parts + 1).astype(int)
    for a, b in zip(bounds[:-1], bounds[1:]):
        sub = Poses(**{f: getattr(p, f)[a:b] for f in Poses.__dataclass_fields__})
        yield step[a:b], t[a:b], sub


def test_poses_read_back_value_for_value_and_as_the_csv_prints_them(tmp_path):
    target = str(tmp_path / "p.parquet")
    entity = np.array(["1:2:3", "tank a", "1:2:3"] * 1000)
    text = []
    with P.PosesParquetWriter(target, metadata=P.output_metadata("WKT"), entity=True) as w:
        k = 0
        for step, t, p in _chunks():
            w.write_chunk(step, t, p, PLACED_BY, STATUS, entity=entity[k:k + len(step)])
            text.append(format_rows(step, t, p, PLACED_BY, STATUS))
            k += len(step)
    table = pq.read_table(target)
    assert pq.ParquetFile(target).num_row_groups == 3
    assert table.column_names == list(COLUMNS) + ["entity"]
    assert pa.types.is_dictionary(table.schema.field("matcher").type) and table.schema.field("step").type == pa.int64()
    # value for value what was written
    expected = [P.pose_columns(s, t, p, PLACED_BY, STATUS) for s, t, p in _chunks()]
    for name in COLUMNS:
        got = table.column(name).to_pylist()
        first = expected[0][name]
        if isinstance(first, P.Coded):
            want = [first.labels[c] for e in expected for c in e[name].codes.tolist()]
        elif isinstance(first, P.Masked):
            want = [None if null else v for e in expected for v, null in zip(e[name].values.tolist(), e[name].null)]
        else:
            want = np.concatenate([e[name] for e in expected]).tolist()
        assert got == want, name
    # the numbers are the poses' own
    p = poses(3000)
    posed = p.status != 2
    np.testing.assert_array_equal(np.array(table.column("roll_deg").to_pylist(), float)[posed], np.degrees(p.roll[posed]))
    np.testing.assert_array_equal(np.array(table.column("x").to_pylist(), float), p.position[:, 0])
    assert table.column("entity").to_pylist() == entity.tolist()
    # and as the CSV prints them: empty cells are nulls, numbers equal to the CSV's decimals
    rows = list(csv.reader(io.StringIO("".join(text))))
    decimals = dict(zip(COLUMNS, [0, 6, 4, 4, 4, 5, 5, 5, 8, 8, 8, 8, None, None, 4, 4, None]))
    for j, name in enumerate(COLUMNS):
        got = table.column(name).to_pylist()
        cells = [r[j] for r in rows]
        assert [g is None for g in got] == [c == "" for c in cells], name
        if decimals[name] is None:
            assert got == cells, name
        else:
            g = np.array([np.nan if v is None else v for v in got], dtype=float)
            c = np.array([np.nan if v == "" else float(v) for v in cells])
            ok = np.isnan(c) | (np.abs(g - c) <= 0.5 * 10.0 ** -decimals[name] * (1 + 1e-9) + 1e-9)
            assert ok.all(), name


def test_metadata_round_trip(tmp_path):
    src = tmp_path / "track.csv"
    src.write_bytes(b"t,x,y,yaw_deg\n0,1,2,3\n")
    meta = P.output_metadata("PROJCRS[\"x\"]", sources=[str(src)], matcher="auto", extra_list=[1, 2])
    target = str(tmp_path / "p.parquet")
    with P.ParquetTableWriter(target, [("a", "float64")], metadata=meta) as w:
        w.write({"a": np.arange(3.0)})
    kv = {k.decode(): v.decode() for k, v in pq.read_metadata(target).metadata.items() if not k.startswith(b"ARROW")}
    assert kv == meta
    import json

    from tankcd_cli import __version__

    assert kv["tankcd.version"] == __version__ and kv["tankcd.crs_wkt"] == "PROJCRS[\"x\"]"
    assert json.loads(kv["tankcd.sources"]) == [{"path": str(src), "sha256": hashlib.sha256(src.read_bytes()).hexdigest()}]
    assert json.loads(kv["tankcd.extra_list"]) == [1, 2] and kv["tankcd.matcher"] == "auto"
    assert "REP 103" in kv["tankcd.conventions"]


def test_atomic_nothing_left_on_an_error_mid_write(tmp_path):
    target = tmp_path / "p.parquet"
    target.write_bytes(b"the previous output")
    with pytest.raises(RuntimeError, match="mid-write"):
        with P.ParquetTableWriter(str(target), [("a", "int64")]) as w:
            w.write({"a": np.arange(10)})
            raise RuntimeError("mid-write")
    assert target.read_bytes() == b"the previous output"
    assert sorted(os.listdir(tmp_path)) == ["p.parquet"]
    w = P.ParquetTableWriter(str(tmp_path / "q.parquet"), [("a", "int64")])
    w.write({"a": np.arange(10)})
    assert not (tmp_path / "q.parquet").exists()  # not there before it is complete
    w.abort()
    assert sorted(os.listdir(tmp_path)) == ["p.parquet"]


def test_committed_together_with_the_other_outputs(tmp_path):
    from tankcd_cli.io.atomic import committed_together, output_text

    with committed_together():
        with P.ParquetTableWriter(str(tmp_path / "p.parquet"), [("a", "int64")]) as w:
            w.write({"a": [1, 2]})
        with output_text(str(tmp_path / "e.jsonl")) as fh:
            fh.write("{}\n")
        assert not (tmp_path / "p.parquet").exists()
    assert pq.read_table(str(tmp_path / "p.parquet")).column("a").to_pylist() == [1, 2]


def test_every_kind_of_column(tmp_path):
    schema = [("f", "float64"), ("i", "int64"), ("i32", "int32"), ("i16", "int16"), ("u8", "uint8"), ("b", "bool"),
              ("s", "string"), ("d", "dict"), ("c", "dict"), ("j", "json"), ("missing", "float64")]
    target = str(tmp_path / "k.parquet")
    with P.ParquetTableWriter(target, schema) as w:
        w.write({"f": [1.5, np.nan, -np.inf], "i": [1, -2, 2**62], "i32": [1, 2, 3], "i16": np.array([-3, 0, 3]),
                 "u8": np.array([0, 7, 255]), "b": [True, False, True], "s": np.array(["x", "yy", ""]),
                 "d": ["a", None, "a"], "c": P.Coded(np.array([1, 0, 5]), ["p", "q"]), "j": ['{"k":1}', None, "[]"]})
        w.write({"f": [], "i": []})  # an empty batch is a valid (empty) row group
    t = pq.read_table(target)
    assert t.column("f").to_pylist() == [1.5, None, -np.inf]
    assert t.column("i").to_pylist() == [1, -2, 2**62]
    assert [t.schema.field(n).type for n in ("i32", "i16", "u8", "b")] == [pa.int32(), pa.int16(), pa.uint8(), pa.bool_()]
    assert t.column("s").to_pylist() == ["x", "yy", ""] and t.column("d").to_pylist() == ["a", None, "a"]
    assert t.column("c").to_pylist() == ["q", "p", None] and t.column("j").to_pylist() == ['{"k":1}', None, "[]"]
    assert t.column("missing").to_pylist() == [None] * 3
    with pytest.raises(ValueError, match="not in the schema"):
        with P.ParquetTableWriter(str(tmp_path / "bad.parquet"), schema) as w:
            w.write({"nope": [1]})
    assert not (tmp_path / "bad.parquet").exists()


def test_events_typed_columns_and_the_rest_as_json(tmp_path):
    from tankcd_cli.replay.records import Event

    events = [
        Event(3, 0.3, "obstacle", "hull", "wall", {"point": [1.0, 2.0, 3.5], "contacts": 4}),
        Event(4, 0.4, "terrain", "hull", "terrain", {"depth": 0.0123}),
        Event(5, 0.5, "internal", "gun", "drum_1", {"turret_deg": 12.5, "gun_deg": -3.0}),
        Event(6, float("nan"), "off_terrain", "vehicle", "terrain", {"status": "off"}),
        {"step": 7, "t": 0.75, "kind": "vehicle", "a": "1:1:1", "b": "1:1:2", "a_part": "hull", "b_part": "gun",
         "between": True, "point": [5, 6, 7], "closing_speed": 3.25, "entity": "1:1:1", "method": "swept",
         "note": {"nested": [1, 2]}, "contacts": "many"},
    ]
    target = str(tmp_path / "e.parquet")
    with P.EventsParquetWriter(target, metadata={"k": "v"}) as w:
        w.write_events(events[:2])
        w.write_events([])
        w.write_events(events[2:])
    table = pq.read_table(target)
    assert table.column_names == [n for n, _ in P.EVENT_SCHEMA]
    assert table.column("between").to_pylist() == [None] * 4 + [True]
    assert table.column("point_z").to_pylist() == [3.5, None, None, None, 7.0]
    assert table.column("t").to_pylist()[3] is None
    back = P.event_dicts(table)
    want = [{"step": e.step, "t": e.t, "kind": e.kind, "a": e.a, "b": e.b, **e.extra} if not isinstance(e, dict) else e
            for e in events]
    want[3]["t"] = None
    want[4] = dict(want[4], point=[5.0, 6.0, 7.0])
    assert back == want
    assert table.column("extra").to_pylist()[4] == '{"note":{"nested":[1,2]},"contacts":"many"}'


def test_without_pyarrow_one_line_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    target = str(tmp_path / "p.parquet")
    with pytest.raises(P.ParquetUnavailable) as info:
        P.PosesParquetWriter(target)
    assert str(info.value) == f"{target}: Parquet output needs pyarrow: pip install 'tankcd[parquet]'"
    assert info.value.what == P.PYARROW_MISSING and isinstance(info.value, InputError)  # bad input: exit 3
    assert os.listdir(tmp_path) == []
    with pytest.raises(P.ParquetUnavailable, match="^e.parquet: Parquet output needs pyarrow"):
        P.check_writable("-", None, "p.csv", "e.parquet")
    P.check_writable("-", None, "p.csv")  # nothing asks for Parquet: nothing to check
    assert P.is_parquet("out/P.PARQUET") and not P.is_parquet("p.csv") and not P.is_parquet(None)


def test_threaded_writing_gives_the_same_file_and_its_errors(tmp_path, monkeypatch):
    plain, threaded = str(tmp_path / "a.parquet"), str(tmp_path / "b.parquet")
    for target, flag in ((plain, False), (threaded, True)):
        with P.PosesParquetWriter(target, threaded=flag) as w:
            for step, t, p in _chunks():
                w.write_chunk(step, t, p, PLACED_BY, STATUS)
        assert w.rows == 3000
    assert pq.read_table(threaded).equals(pq.read_table(plain))
    assert pq.ParquetFile(threaded).num_row_groups == 3
    # an error while a row group is written in the thread: raised by close, nothing left behind
    w = P.ParquetTableWriter(str(tmp_path / "c.parquet"), [("a", "int64")], threaded=True)

    def fail(table):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(w._writer, "write_table", fail)
    w.write({"a": np.arange(5)})
    with pytest.raises(InputError, match="c.parquet: cannot write output: No space left on device"):
        w.close()  # bad output (exit 3), named, as io.atomic says it of text outputs
    assert sorted(os.listdir(tmp_path)) == ["a.parquet", "b.parquet"]
