"""read_review against a real replay: an exercise of three vehicles (a contact between two, one
driving into a wall and off the terrain) replayed to CSV + JSON Lines and to Parquet. Both reviews
agree with each other and with the poses read independently (the csv module); every consistency
check between poses and events refuses a file broken on purpose, in one line naming the file and
the line, row or event."""

import csv
import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.report.inputs import read_poses_csv, read_review
from tankcd_cli.report.review import STATUS
from tests.replay.scenes import flat, hull_mesh, scene

FIELDS = ("step", "t", "x", "y", "z", "yaw_deg", "quaternion", "status")


def exercise_rows(shift=0.0) -> str:
    rows = ["t,entity,x,y,yaw_deg"]
    for k in range(21):
        t = k * 0.5
        rows.append(f"{t},alpha,{20 + k * 1.0 + shift},30,0")  # drives east, meets bravo
        rows.append(f"{t},bravo,{52 - k * 1.0},30.5,180")  # drives west
        rows.append(f"{t},charlie,{100 + k * 1.5},10,0")  # into the wall, then off the east edge
    return "\n".join(rows) + "\n"


def replay(d: Path, name: str, rows: str, poses: str, events: str):
    from tankcd_cli import api

    (d / name).write_text(rows)
    api.replay_to_files(str(d / name), poses=str(d / poses), events=str(d / events), scene=str(d / "scene.toml"))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("exercise")
    flat(d)
    scene(d, [("wall", [108.0, 5.0, 99.0], [109.0, 15.0, 104.0])], hull_mesh(d))
    replay(d, "ex.csv", exercise_rows(), "p.csv", "e.jsonl")
    if _have_pyarrow():
        replay(d, "ex.csv", exercise_rows(), "p.parquet", "e.parquet")
        replay(d, "other.csv", exercise_rows(shift=0.25), "other.parquet", "other_e.parquet")
    (d / "one.csv").write_text("t,x,y,yaw_deg\n" + "".join(f"{0.5 * k},{100 + 1.5 * k},10,0\n" for k in range(21)))
    from tankcd_cli import api

    api.replay_to_files(str(d / "one.csv"), poses=str(d / "one_p.csv"), events=str(d / "one_e.jsonl"),
                        scene=str(d / "scene.toml"))
    return d


def _have_pyarrow() -> bool:
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        return False
    return True


def csv_tracks(path: Path) -> dict:
    """The poses CSV by the csv module: entity -> {field: array} in file order (empty cells NaN)."""
    out: dict = {}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            tr = out.setdefault(row.get("entity", ""), {f: [] for f in FIELDS})
            for f in ("step", "t", "x", "y", "z", "yaw_deg"):
                tr[f].append(float(row[f]) if row[f] != "" else math.nan)
            tr["quaternion"].append([float(row[c]) if row[c] != "" else math.nan for c in ("qw", "qx", "qy", "qz")])
            tr["status"].append(STATUS.index(row["status"]))
    return {e: {f: np.array(v) for f, v in tr.items()} for e, tr in out.items()}


def assert_same_tracks(review, want: dict, tol: float = 0.0):
    assert [tr.entity for tr in review.tracks] == list(want)
    for tr in review.tracks:
        w = want[tr.entity]
        assert tr.step.dtype == np.int64 and tr.status.dtype == np.uint8 and tr.t.dtype == np.float64
        assert tr.quaternion.shape == (len(tr), 4)
        for f in FIELDS:
            got, exp = getattr(tr, f), w[f]
            assert got.shape == exp.shape, f
            assert (np.isnan(got) == np.isnan(exp)).all(), (tr.entity, f)
            ok = np.isnan(exp) | (np.abs(got - exp) <= tol)
            assert ok.all(), (tr.entity, f, got[~ok][:3], exp[~ok][:3])


def test_the_csv_review_is_the_poses_as_the_csv_module_reads_them(run):
    review = read_review(str(run / "p.csv"), str(run / "e.jsonl"))
    want = csv_tracks(run / "p.csv")
    assert list(want) == ["alpha", "bravo", "charlie"]
    assert_same_tracks(review, want)
    charlie = review.track("charlie")
    assert (charlie.status == STATUS.index("off")).any() and np.isnan(charlie.z[charlie.status == 2]).all()
    assert np.isfinite(charlie.x).all()  # an off row keeps its position
    events = [json.loads(line) for line in (run / "e.jsonl").read_text().splitlines()]
    assert review.events == events
    kinds = {e["kind"] for e in events}
    assert {"vehicle", "obstacle", "off_terrain"} <= kinds, kinds
    sha = {s.role: s.sha256 for s in review.sources}
    assert sha["poses"] == hashlib.sha256((run / "p.csv").read_bytes()).hexdigest()
    assert sha["events"] == hashlib.sha256((run / "e.jsonl").read_bytes()).hexdigest()
    assert review.settings == {} and review.crs_wkt == ""


def test_small_blocks_read_as_one(run):
    """Blocks cut anywhere (here every few hundred bytes, also inside lines) give the same tracks."""
    whole = read_poses_csv(str(run / "p.csv"))
    for block in (97, 300, 4096):
        parts = read_poses_csv(str(run / "p.csv"), block=block)
        assert [t.entity for t in parts] == [t.entity for t in whole]
        for a, b in zip(parts, whole):
            for f in FIELDS:
                np.testing.assert_array_equal(getattr(a, f), getattr(b, f))


def test_a_replay_without_entities_is_one_unnamed_track(run):
    review = read_review(str(run / "one_p.csv"), str(run / "one_e.jsonl"))
    assert [tr.entity for tr in review.tracks] == [""]
    assert_same_tracks(review, csv_tracks(run / "one_p.csv"))
    assert len(review.events) > 0


def test_parquet_and_csv_reviews_agree(run):
    pytest.importorskip("pyarrow")
    a = read_review(str(run / "p.csv"), str(run / "e.jsonl"))
    b = read_review(str(run / "p.parquet"), str(run / "e.parquet"))
    # the CSV rounds to 4 decimals (positions), 5 (angles), 6 (t), 8 (quaternion)
    assert_same_tracks(b, {tr.entity: {f: getattr(tr, f) for f in FIELDS} for tr in a.tracks}, tol=0.5e-4 + 1e-12)
    assert len(a.events) == len(b.events)
    for x, y in zip(a.events, b.events):
        assert set(x) == set(y) and x["step"] == y["step"] and abs(x["t"] - y["t"]) <= 0.5e-6 + 1e-12
    roles = {s.role for s in b.sources}
    assert {"poses", "events", "trajectory", "scene", "terrain"} <= roles
    traj = [s for s in b.sources if s.role == "trajectory"]
    assert traj[0].sha256 == hashlib.sha256((run / "ex.csv").read_bytes()).hexdigest()
    assert b.settings["mode"] == "continuous" and b.tankcd_version
    mixed = read_review(str(run / "p.csv"), str(run / "e.parquet"))  # one of each
    assert mixed.settings == b.settings and len(mixed.events) == len(b.events)


def test_parquet_files_of_different_runs_are_refused(run):
    pytest.importorskip("pyarrow")
    with pytest.raises(InputError, match="poses and events come from different runs") as err:
        read_review(str(run / "p.parquet"), str(run / "other_e.parquet"))
    assert "\n" not in str(err.value) and str(run / "other_e.parquet") in str(err.value)


def _events(run) -> list:
    return [json.loads(line) for line in (run / "e.jsonl").read_text().splitlines()]


def _write_events(tmp_path, events, extra_lines=()) -> str:
    path = tmp_path / "bad.jsonl"
    path.write_text("".join(json.dumps(e) + "\n" for e in events) + "".join(extra_lines))
    return str(path)


def _refused(run, events_path, match, poses="p.csv"):
    with pytest.raises(InputError, match=match) as err:
        read_review(str(run / poses), events_path)
    text = str(err.value)
    assert "\n" not in text and text.startswith(events_path), text
    return text


def _first(events, kind):
    return next(i for i, e in enumerate(events) if e["kind"] == kind)


def test_an_event_at_no_pose_rows_step_is_refused(run, tmp_path):
    events = _events(run)
    events[1]["step"] = 10_000
    text = _refused(run, _write_events(tmp_path, events), "step 10000 is no pose row's step")
    assert "line 2 (event 2)" in text


def test_an_event_of_an_unknown_entity_is_refused(run, tmp_path):
    events = _events(run)
    events[0]["entity"] = "delta"
    _refused(run, _write_events(tmp_path, events), "entity 'delta' has no pose rows")
    events = _events(run)
    k = _first(events, "vehicle")
    events[k]["b"] = "echo"
    text = _refused(run, _write_events(tmp_path, events), "b 'echo' has no pose rows")
    assert f"line {k + 1}" in text


def test_an_event_at_a_step_of_another_vehicle_is_refused(run, tmp_path):
    events = _events(run)
    alpha_step = int(read_poses_csv(str(run / "p.csv"))[0].step[0])
    k = next(i for i, e in enumerate(events) if e.get("entity") == "charlie")
    events[k]["step"] = alpha_step
    _refused(run, _write_events(tmp_path, events), f"step {alpha_step} is not a row of charlie")


def test_an_event_at_a_row_off_its_rows_time_is_refused(run, tmp_path):
    events = _events(run)
    k = next(i for i, e in enumerate(events) if not e.get("between"))
    events[k]["t"] += 2e-6
    _refused(run, _write_events(tmp_path, events), "is not its row's t")
    events[k]["t"] -= 1.5e-6  # within the slack: read
    read_review(str(run / "p.csv"), _write_events(tmp_path, events))


def test_an_event_between_rows_outside_its_interval_is_refused(run, tmp_path):
    events = _events(run)
    k = next(i for i, e in enumerate(events) if e.get("between"))
    events[k]["t"] += 0.5  # rows are 0.5 s apart: past the next row
    _refused(run, _write_events(tmp_path, events), "of an event between rows lies outside")
    events = _events(run)
    tracks = {tr.entity: tr for tr in read_poses_csv(str(run / "p.csv"))}
    tr = tracks[events[k]["entity"]]
    row = int(np.flatnonzero(tr.step == events[k]["step"])[0])
    events[k]["t"] = float(tr.t[row + 1])  # at the next row: still in the interval
    read_review(str(run / "p.csv"), _write_events(tmp_path, events))
    events[k]["t"] = float(tr.t[row]) - 0.01
    _refused(run, _write_events(tmp_path, events), "of an event between rows lies outside")


def test_a_malformed_json_line_is_named(run, tmp_path):
    events = _events(run)
    path = _write_events(tmp_path, events[:3], ['{"step": 1, "t": \n'])
    assert "line 4" in _refused(run, path, "not a JSON object")
    path = _write_events(tmp_path, events[:3], ["[1, 2]\n"])
    assert "line 4" in _refused(run, path, "not a JSON object")


def _broken_poses(run, tmp_path, line_no: int, column: str, value: str) -> str:
    lines = (run / "p.csv").read_text().splitlines(keepends=True)
    header = lines[0].rstrip("\n").split(",")
    cells = lines[line_no - 1].rstrip("\n").split(",")
    cells[header.index(column)] = value
    lines[line_no - 1] = ",".join(cells) + "\n"
    path = tmp_path / "bad_poses.csv"
    path.write_text("".join(lines))
    return str(path)


@pytest.mark.parametrize("column, value, match", [
    ("x", "nan", "non-finite value 'nan'"),
    ("t", "inf", "non-finite value 'inf'"),
    ("z", "", "z is empty or not finite on a row with status ok"),
    ("qx", "", "qx is empty or not finite on a row with status ok"),
    ("y", "north", "not a number: 'north'"),
    ("status", "sideways", "status 'sideways' is not one of ok, partly_off, off"),
])
def test_bad_pose_rows_are_named_by_line(run, tmp_path, column, value, match):
    path = _broken_poses(run, tmp_path, 5, column, value)
    with pytest.raises(InputError, match=match) as err:
        read_review(path, str(run / "e.jsonl"))
    text = str(err.value)
    assert "\n" not in text and text.startswith(path) and "line 5" in text, text


def test_an_off_row_without_a_position_is_refused(run, tmp_path):
    lines = (run / "p.csv").read_text().splitlines()
    k = next(i for i, line in enumerate(lines) if line.endswith(",off"))
    path = _broken_poses(run, tmp_path, k + 1, "x", "")
    with pytest.raises(InputError, match="x or y is empty") as err:
        read_review(path, str(run / "e.jsonl"))
    assert f"line {k + 1}" in str(err.value)


def test_poses_without_the_columns_a_review_needs_are_refused(run, tmp_path):
    path = tmp_path / "traj_as_poses.csv"
    path.write_text((run / "ex.csv").read_text())
    with pytest.raises(InputError, match="header lacks the poses columns step, z") as err:
        read_review(str(path), str(run / "e.jsonl"))
    assert "\n" not in str(err.value)


def test_parquet_without_pyarrow_is_one_line_naming_the_extra(run, monkeypatch):
    import sys

    pytest.importorskip("pyarrow")  # (the fixture wrote the Parquet files with it)
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(InputError, match=r"p\.parquet: reading Parquet needs pyarrow: pip install 'tankcd\[parquet\]'"):
        read_review(str(run / "p.parquet"), str(run / "e.jsonl"))


def test_swapped_parquet_files_are_refused(run):
    pytest.importorskip("pyarrow")
    with pytest.raises(InputError, match="lacks the poses columns") as err:
        read_review(str(run / "e.parquet"), str(run / "p.parquet"))
    assert str(err.value).startswith(str(run / "e.parquet"))


def test_a_contact_where_a_vehicle_begins_is_at_that_vehicles_row(tmp_path):
    """bravo's first row (t 5.25) lies on alpha, between alpha's rows at 5.0 and 5.5: the replay
    reports the contact at bravo's row (no "between"), with alpha's step; it is read, not refused."""
    from tankcd_cli import api

    flat(tmp_path)
    scene(tmp_path)
    rows = ["t,entity,x,y,yaw_deg"] + [f"{k * 0.5},alpha,{20 + k * 1.0},30,0" for k in range(21)]
    rows += [f"{5.25 + k * 0.5},bravo,30,30.5,0" for k in range(10)]
    (tmp_path / "late.csv").write_text("\n".join(rows) + "\n")
    api.replay_to_files(str(tmp_path / "late.csv"), poses=str(tmp_path / "p.csv"), events=str(tmp_path / "e.jsonl"),
                        scene=str(tmp_path / "scene.toml"))
    review = read_review(str(tmp_path / "p.csv"), str(tmp_path / "e.jsonl"))
    (event,) = [e for e in review.events if e["kind"] == "vehicle"]
    alpha = review.track("alpha")
    assert not event.get("between") and event["t"] == 5.25
    assert alpha.t[np.flatnonzero(alpha.step == event["step"])[0]] == 5.0  # alpha's row is not the event's time
    broken = dict(event, b_step=int(alpha.step[0]))  # b's row elsewhere: the time matches neither row
    (tmp_path / "bad.jsonl").write_text(json.dumps(broken) + "\n")
    with pytest.raises(InputError, match="is not its row's t"):
        read_review(str(tmp_path / "p.csv"), str(tmp_path / "bad.jsonl"))


def test_an_event_without_entity_in_an_exercise_is_refused(run, tmp_path):
    events = _events(run)
    k = next(i for i, e in enumerate(events) if e["kind"] != "vehicle")
    del events[k]["entity"]
    _refused(run, _write_events(tmp_path, events), "the event names no entity")


@pytest.mark.parametrize("form", ["crlf", "reordered", "bom"])
def test_columns_by_name_and_line_endings_read_alike(run, tmp_path, form):
    """The same poses with CRLF line breaks, a BOM, or the columns in another order (rewritten with
    the csv module) give the same tracks."""
    text = (run / "p.csv").read_text()
    path = tmp_path / f"{form}.csv"
    if form == "crlf":
        path.write_bytes(text.replace("\n", "\r\n").encode())
    elif form == "bom":
        path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    else:
        rows = list(csv.reader(text.splitlines()))
        order = list(reversed(range(len(rows[0]))))
        with open(path, "w", newline="") as fh:
            csv.writer(fh, lineterminator="\n").writerows([[r[j] for j in order] for r in rows])
    got = read_review(str(path), str(run / "e.jsonl"))
    assert_same_tracks(got, csv_tracks(run / "p.csv"))
