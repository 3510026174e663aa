"""What ``info`` says of replay's outputs: events (JSON Lines), Parquet poses and events, a replay
summary and fleet.json, each fact against what made the file (a replay of the sample, the summary
it returned, events counted by hand), and the JSON Lines and Parquet counts of the same events
against a count of their own."""

import hashlib
import json
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.describe import describe_store
from tankcd_cli.describe_outputs import json_kind
from tankcd_cli.errors import InputError
from tankcd_cli.io.events import event_line

SAMPLE = Path(__file__).resolve().parents[1] / "sample_data"
TRAJECTORY = SAMPLE / "patrol.csv"


@pytest.fixture(scope="module")
def replayed(tmp_path_factory):
    """The sample patrol replayed in its scene: its events as JSON Lines and the summary as JSON;
    and a fleet of it and a bad trajectory, as Parquet (poses and events) with fleet.json."""
    from tankcd_cli import api

    out = tmp_path_factory.mktemp("outputs")
    summary = api.replay_to_files(str(TRAJECTORY), str(out / "poses.csv"), str(out / "events.jsonl"),
                                  scene=str(SAMPLE / "scene.toml"))
    (out / "summary.json").write_text(json.dumps(summary.as_dict(), indent=2) + "\n")
    bad = out / "bad.csv"
    bad.write_text("t,x,y,yaw_deg\n0,500010,4500080,0\n1,oops,4500080,0\n")
    fleet = api.replay_fleet([str(TRAJECTORY), str(bad)], str(out / "fleet"), scene=str(SAMPLE / "scene.toml"), jobs=1,
                             out_format="parquet")
    for name in ("poses", "events"):
        (out / f"{name}.parquet").hardlink_to(out / "fleet" / f"patrol.{name}.parquet")
    return out, summary, fleet


def test_events_jsonl_counts_agree_with_the_replay_summary(replayed):
    out, summary, _ = replayed
    facts = describe_store(str(out / "events.jsonl"))
    assert facts["kind"] == "events" and facts["format"] == "JSON Lines"
    for kind, n in summary.collisions.items():  # every event is a contact at a row or one between rows
        assert facts["by_kind"].get(kind, 0) == n + summary.between.get(kind, 0)
    assert facts["between"] == sum(summary.between.values())
    assert facts["between_fraction"] == pytest.approx(facts["between"] / facts["events"], abs=1e-6)
    lines = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    assert facts["events"] == len(lines)
    assert facts["t_first"] == min(e["t"] for e in lines) and facts["t_last"] == max(e["t"] for e in lines)
    assert facts["obstacles"] == dict(Counter(e["b"] for e in lines if e["kind"] == "obstacle"))
    assert facts["entities"] == {}  # one vehicle: no entity column
    assert json.loads(json.dumps(facts)) == facts


def test_parquet_events_say_the_same_counts_and_their_metadata(replayed):
    out, summary, _ = replayed
    text = describe_store(str(out / "events.jsonl"))
    facts = describe_store(str(out / "events.parquet"))
    assert facts["kind"] == "events (Parquet)" and facts["table"] == "events" and facts["rows"] == text["events"]
    for key in ("events", "by_kind", "between", "between_fraction", "t_first", "t_last", "step_first", "step_last",
                "obstacles", "parts", "entities"):
        assert facts[key] == pytest.approx(text[key]) if isinstance(text[key], float) else facts[key] == text[key], key
    assert facts["replay"] == {"matcher": "auto", "escalate": None, "tolerance": None, "attitude_tolerance": None,
                               "mode": "continuous", "time_origin": None}
    trajectory = [s for s in facts["sources"] if s["role"] == "trajectory"]
    assert trajectory == [{"role": "trajectory", "path": str(TRAJECTORY),
                           "sha256": hashlib.sha256(TRAJECTORY.read_bytes()).hexdigest()}]
    assert facts["crs"] == "local grid (no CRS)" and facts["units"] == "m, s, deg"
    assert facts["tankcd_version"] and facts["row_groups"] == 1
    assert json.loads(json.dumps(facts)) == facts


def test_parquet_poses_rows_span_and_statuses(replayed):
    import pyarrow.parquet as pq

    out, summary, _ = replayed
    facts = describe_store(str(out / "poses.parquet"))
    table = pq.read_table(out / "poses.parquet")
    assert facts["kind"] == "poses (Parquet)" and facts["rows"] == summary.rows == table.num_rows
    assert facts["columns"] == table.column_names and "entities" not in facts
    assert facts["step_first"] == 0 and facts["step_last"] == summary.rows - 1
    t = table.column("t").to_pylist()
    assert facts["t_first"] == min(t) and facts["t_last"] == max(t)
    assert facts["status"] == dict(Counter(table.column("status").to_pylist()))
    assert sum(facts["status"].values()) == summary.rows


def test_a_poses_csv_says_what_its_parquet_says(replayed, tmp_path):
    from tankcd_cli.io.poses_csv import header

    out, summary, _ = replayed
    facts = describe_store(str(out / "poses.csv"))
    parquet = describe_store(str(out / "poses.parquet"))
    assert facts["kind"] == "poses (CSV)" and facts["rows"] == summary.rows
    for key in ("rows", "columns", "step_first", "step_last", "t_first", "t_last", "status"):
        assert facts[key] == parquet[key], key
    rows = "".join(f"{k},{name},{0.5 * k:.6f}" + ",0" * 10 + ",flat,two_point,,," + status + "\n"
                   for k, (name, status) in enumerate([("T-72 4", "ok"), ("bravo", "off"), ("T-72 4", "ok")]))
    (tmp_path / "exercise.csv").write_text(header(entity=True) + rows)
    from tankcd_cli.describe_outputs import _poses_csv_by_arrow, _poses_csv_by_lines

    for path in (out / "poses.csv", tmp_path / "exercise.csv"):  # pyarrow's reader and the line reader agree
        assert _poses_csv_by_arrow(str(path)) == _poses_csv_by_lines(str(path)) == describe_store(str(path))
    facts = describe_store(str(tmp_path / "exercise.csv"))
    assert facts["entities"] == {"T-72 4": 2, "bravo": 1} and facts["status"] == {"ok": 2, "off": 1}
    assert (facts["step_first"], facts["step_last"], facts["t_first"], facts["t_last"]) == (0, 2, 0.0, 1.0)
    (tmp_path / "cut.csv").write_text(header() + "0,0.000000,1,2\n")
    with pytest.raises(InputError, match="cut.csv: line 2: expected 17 columns as in the header, found 4"):
        describe_store(str(tmp_path / "cut.csv"))


def test_a_replay_summary_shows_its_fields_and_warnings(replayed, tmp_path):
    out, summary, _ = replayed
    facts = describe_store(str(out / "summary.json"))
    assert facts["kind"] == "replay summary"
    assert {k: facts[k] for k in summary.as_dict()} == summary.as_dict()
    one_line = tmp_path / "stderr.json"  # replay --summary prints one line: the same summary
    one_line.write_text(json.dumps({**summary.as_dict(), "warnings": ["t.csv: line 3: a warning"]}) + "\n")
    facts = describe_store(str(one_line))
    assert facts["kind"] == "replay summary" and facts["warnings"] == ["t.csv: line 3: a warning"]


def test_fleet_json_trajectories_ok_and_failed(replayed):
    out, _, fleet = replayed
    facts = describe_store(str(out / "fleet" / "fleet.json"))
    assert facts["kind"] == "fleet summary (fleet.json)"
    assert (facts["trajectories"], facts["ok"], facts["failed"]) == (2, 1, 1)
    assert facts["rows"] == fleet.rows and facts["collisions"] == fleet.collisions
    assert facts["world"]["scene"] == str(SAMPLE / "scene.toml")
    assert [f["status"] for f in facts["failures"]] == ["bad_input"] and "line 3" in facts["failures"][0]["error"]
    ok, bad = facts["results"]
    assert ok["trajectory"] == str(TRAJECTORY) and ok["status"] == "ok" and ok["rows"] == fleet.rows
    assert bad["status"] == "bad_input" and "rows" not in bad and bad["error"]


# --- the counts, against a count of their own -------------------------------------------------------

NAMES = st.sampled_from(["wall", "depot", "hut_2"])
PARTS = st.sampled_from(["hull", "gun", "track_left", "turret"])
ENTITIES = st.sampled_from(["alpha", "bravo", "T-72 4"])


@st.composite
def events(draw):
    out = []
    for step in range(draw(st.integers(1, 25))):
        kind = draw(st.sampled_from(["obstacle", "internal", "terrain", "off_terrain", "vehicle"]))
        t = draw(st.one_of(st.none(), st.floats(0, 1e4)))
        extra = {}
        if draw(st.booleans()):
            extra["between"] = True
        entity = draw(st.one_of(st.none(), ENTITIES))
        if kind == "obstacle":
            a, b = draw(PARTS), draw(NAMES)
        elif kind == "internal":
            a, b = "gun", draw(st.sampled_from(["drum_left", "drum_right"]))
        elif kind == "terrain":
            a, b = "hull", "terrain"
        elif kind == "off_terrain":
            a, b = "vehicle", "terrain"
        else:
            a, b = sorted(draw(st.lists(ENTITIES, min_size=2, max_size=2, unique=True)))
            extra.update(a_part=draw(PARTS), b_part=draw(PARTS))
            entity = a
        if entity is not None:
            extra["entity"] = entity
        out.append((step, t, kind, a, b, extra))
    return out


def _count(evts):
    """The facts by hand: obstacles by b, parts by a (or a_part and b_part), entities both vehicles."""
    kinds, obstacles, parts, entities = Counter(), Counter(), Counter(), Counter()
    for step, t, kind, a, b, extra in evts:
        kinds[kind] += 1
        if kind == "obstacle":
            obstacles[b] += 1
        if kind in ("obstacle", "internal", "terrain"):
            parts[a] += 1
        if kind == "vehicle":
            parts[extra["a_part"]] += 1
            parts[extra["b_part"]] += 1
            entities[a] += 1
            entities[b] += 1
        elif "entity" in extra:
            entities[extra["entity"]] += 1
    return kinds, obstacles, parts, entities


@pytest.fixture(scope="module")
def counts_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("counts")


@settings(max_examples=10, deadline=None)
@given(evts=events())
def test_jsonl_and_parquet_counts_are_the_events_counted(counts_dir, evts):
    from tankcd_cli.io.parquet import EventsParquetWriter

    out = counts_dir
    (out / "e.jsonl").write_text("".join(event_line(s, t, k, a, b, **x) for s, t, k, a, b, x in evts))
    with EventsParquetWriter(str(out / "e.parquet"), {"tankcd.table": "events"}) as w:
        w.write_events([{"step": s, "t": t, "kind": k, "a": a, "b": b, **x} for s, t, k, a, b, x in evts])
    kinds, obstacles, parts, entities = _count(evts)
    times = [round(t, 6) for _, t, *_ in evts if t is not None]
    from tankcd_cli.describe_outputs import _events_jsonl_by_arrow, _events_jsonl_by_lines

    for facts in [describe_store(str(out / "e.parquet")), _events_jsonl_by_lines(str(out / "e.jsonl")),
                  _events_jsonl_by_arrow(str(out / "e.jsonl"))]:
        assert facts["events"] == len(evts) and facts["by_kind"] == dict(kinds)
        assert facts["between"] == sum(1 for *_, x in evts if x.get("between"))
        assert (facts["obstacles"], facts["parts"], facts["entities"]) == (dict(obstacles), dict(parts), dict(entities))
        assert facts["step_first"] == 0 and facts["step_last"] == len(evts) - 1
        if times:
            assert facts["t_first"] == pytest.approx(min(times), abs=1e-6)
            assert facts["t_last"] == pytest.approx(max(times), abs=1e-6)
        assert facts.get("events_without_t", 0) == len(evts) - len(times)


# --- what is not one of them ----------------------------------------------------------------------

def test_json_kinds_by_their_keys(tmp_path):
    (tmp_path / "other.json").write_text(json.dumps({"name": "x"}, indent=2))
    (tmp_path / "list.json").write_text("[1, 2]")
    assert json_kind(str(tmp_path / "other.json")) == "json"
    assert json_kind(str(tmp_path / "list.json")) is None  # not an object: not one of tankcd's
    with pytest.raises(InputError, match="other.json: a JSON file, but not one tankcd writes"):
        describe_store(str(tmp_path / "other.json"))
    (tmp_path / "broken.jsonl").write_text('{"step":1,"t":0,"kind":"terrain","a":"hull","b":"terrain"}\n{"step":\n')
    with pytest.raises(InputError, match=r"broken.jsonl: line 2: not JSON"):
        describe_store(str(tmp_path / "broken.jsonl"))
    (tmp_path / "mixed.jsonl").write_text('{"step":1,"t":0,"kind":"terrain","a":"hull","b":"terrain"}\n{"x":1}\n')
    with pytest.raises(InputError, match=r"mixed.jsonl: line 2: not an event"):
        describe_store(str(tmp_path / "mixed.jsonl"))
    good = '{"step":1,"t":0.5,"kind":"terrain","a":"hull","b":"terrain"}\n'
    (tmp_path / "blank.jsonl").write_text(good + "\n" + good)  # a blank line: read line by line, the same counts
    assert describe_store(str(tmp_path / "blank.jsonl"))["by_kind"] == {"terrain": 2}
    (tmp_path / "two.jsonl").write_text(good + good.strip() + good)  # two objects on one line: not JSON Lines
    with pytest.raises(InputError, match=r"two.jsonl: line 2: not JSON: Extra data"):
        describe_store(str(tmp_path / "two.jsonl"))
    (tmp_path / "cut.json").write_text('{\n  "trajectories": 1,\n')
    with pytest.raises(InputError, match=r"cut.json: line \d+: not valid JSON"):
        describe_store(str(tmp_path / "cut.json"))


def test_parquet_metadata_names_the_crs_and_shows_keys_it_does_not_know(tmp_path):
    from pyproj import CRS

    from tankcd_cli.io.parquet import EventsParquetWriter, output_metadata

    meta = output_metadata(CRS.from_epsg(32633).to_wkt(), [], table="events", time_origin="2026-01-02T10:00:00Z")
    with EventsParquetWriter(str(tmp_path / "e.parquet"), meta) as w:
        w.write_events([{"step": 0, "t": 0.0, "kind": "terrain", "a": "hull", "b": "terrain", "depth": 0.02}])
    facts = describe_store(str(tmp_path / "e.parquet"))
    assert facts["crs"] == "WGS 84 / UTM zone 33N" and facts["crs_wkt"].startswith("PROJCRS[")
    assert facts["time_origin"] == "2026-01-02T10:00:00Z" and facts["sources"] == []
    assert facts["by_kind"] == {"terrain": 1} and facts["rows"] == 1


def test_a_parquet_file_not_of_tankcd_is_refused(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.table({"a": [1, 2]}), tmp_path / "other.parquet")
    with pytest.raises(InputError, match="other.parquet: a Parquet file, but not tankcd's poses or events"):
        describe_store(str(tmp_path / "other.parquet"))
    (tmp_path / "cut.parquet").write_bytes(b"PAR1" + b"\0" * 20)
    with pytest.raises(InputError, match="cut.parquet: not a Parquet file pyarrow can read"):
        describe_store(str(tmp_path / "cut.parquet"))


def test_parquet_poses_of_an_exercise_count_rows_per_entity(tmp_path):
    import numpy as np

    from tankcd_cli.io.parquet import ParquetTableWriter, pose_schema

    entity = np.array(["T-72 4", "bravo", "T-72 4", "T-72 4"])
    with ParquetTableWriter(str(tmp_path / "p.parquet"), pose_schema(True), {"tankcd.table": "poses"}) as w:
        w.write({"step": np.arange(2), "t": np.array([0.0, 0.5]), "entity": entity[:2], "status": ["ok", "off"]})
        w.write({"step": np.arange(2, 4), "t": np.array([1.0, np.nan]), "entity": entity[2:], "status": ["ok", "ok"]})
    facts = describe_store(str(tmp_path / "p.parquet"))
    assert facts["rows"] == 4 and facts["row_groups"] == 2
    assert facts["entities"] == {"T-72 4": 3, "bravo": 1} and facts["status"] == {"off": 1, "ok": 3}
    assert (facts["step_first"], facts["step_last"], facts["t_first"], facts["t_last"]) == (0, 3, 0.0, 1.0)


def test_the_api_describes_as_info_does(replayed):
    from tankcd_cli import api

    out, _, _ = replayed
    assert api.describe(out / "events.jsonl") == describe_store(str(out / "events.jsonl"))
