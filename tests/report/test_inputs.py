"""The report's reader: poses and events read back into tracks, against the files read by the csv
and json modules, and every sign that the two files come from different runs refused."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.report.inputs import read_review
from tankcd_cli.report.review import STATUS
from tests.report.exercise import replay


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("exercise")
    return replay(folder)


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_the_tracks_are_the_poses_rows_by_vehicle(outputs):
    _, poses, events = outputs
    review = read_review(str(poses), str(events))
    rows = _rows(poses)
    assert [tr.entity for tr in review.tracks] == list(dict.fromkeys(r["entity"] for r in rows))
    for tr in review.tracks:
        mine = [r for r in rows if r["entity"] == tr.entity]
        assert len(tr) == len(mine)
        assert tr.step.tolist() == [int(r["step"]) for r in mine]
        for col, arr in (("t", tr.t), ("x", tr.x), ("y", tr.y), ("z", tr.z), ("yaw_deg", tr.yaw_deg)):
            np.testing.assert_array_equal(arr, [float(r[col]) if r[col] else np.nan for r in mine])
        np.testing.assert_array_equal(tr.quaternion, [[float(r[c]) for c in ("qw", "qx", "qy", "qz")] for r in mine])
        assert [STATUS[s] for s in tr.status] == [r["status"] for r in mine]
    with open(events) as fh:
        assert review.events == [json.loads(line) for line in fh]
    assert any(e["kind"] == "vehicle" for e in review.events)
    roles = [s.role for s in review.sources]
    assert roles[:2] == ["poses", "events"] and all(len(s.sha256) == 64 for s in review.sources[:2])


def test_parquet_outputs_read_as_the_text_ones(outputs, tmp_path):
    pytest.importorskip("pyarrow")
    terrain, poses, events = outputs
    _, pq_poses, pq_events = replay(tmp_path, ".parquet", ".parquet")
    text = read_review(str(poses), str(events))
    typed = read_review(str(pq_poses), str(pq_events))
    assert [tr.entity for tr in typed.tracks] == [tr.entity for tr in text.tracks]
    for a, b in zip(text.tracks, typed.tracks):
        assert a.step.tolist() == b.step.tolist()
        np.testing.assert_allclose(b.x, a.x, atol=5e-5)  # the CSV rounds to its decimals
        np.testing.assert_allclose(b.t, a.t, atol=5e-7)
        np.testing.assert_array_equal(a.status, b.status)
    assert [(e["step"], e["kind"], e["a"], e["b"]) for e in typed.events] == \
        [(e["step"], e["kind"], e["a"], e["b"]) for e in text.events]
    assert typed.tankcd_version and typed.settings["mode"] == "continuous"
    assert any(s.role == "trajectory" for s in typed.sources)
    # one file of each run: their trajectories differ
    other = tmp_path / "other"
    other.mkdir()
    (other / "exercise.csv").write_text((tmp_path / "exercise.csv").read_text().replace(",0\n", ",1\n", 1))
    _, _, other_events = replay(other, ".parquet", ".parquet")
    with pytest.raises(InputError, match="another run"):
        read_review(str(pq_poses), str(other_events))


def _events_with(tmp_path, events, change):
    lines = [json.loads(line) for line in open(events)]
    change(lines)
    path = tmp_path / "edited.jsonl"
    path.write_text("".join(json.dumps(e) + "\n" for e in lines))
    return path


@pytest.mark.parametrize("change, message", [
    (lambda ev: ev[0].update(step=10 ** 6), "has no row"),
    (lambda ev: ev[0].update(a="Z"), "does not hold"),
])
def test_events_of_another_run_are_refused_naming_the_line(outputs, tmp_path, change, message):
    _, poses, events = outputs
    path = _events_with(tmp_path, events, change)
    with pytest.raises(InputError, match=message) as err:
        read_review(str(poses), str(path))
    assert "line " in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("shift, between, message", [(5.0, True, "outside its row's interval"),
                                                     (1e-3, False, "differs from its row's t")])
def test_an_event_off_its_rows_time_is_refused(outputs, tmp_path, shift, between, message):
    _, poses, events = outputs
    rows = _rows(poses)
    first_a = next(r for r in rows if r["entity"] == "A")
    bad = {"step": int(first_a["step"]), "t": float(first_a["t"]) + shift, "kind": "terrain", "a": "hull",
           "b": "terrain", "entity": "A", "depth": 0.02, **({"between": True} if between else {})}
    good = {**bad, "t": float(first_a["t"]) + (0.25 if between else 0.0)}
    read_review(str(poses), str(_events_with(tmp_path, events, lambda ev: ev.append(good))))  # within: read
    path = _events_with(tmp_path, events, lambda ev: ev.append(bad))
    with pytest.raises(InputError, match=message):
        read_review(str(poses), str(path))


def test_malformed_inputs_name_their_line(outputs, tmp_path):
    _, poses, events = outputs
    broken = tmp_path / "broken.jsonl"
    broken.write_text(open(events).read() + "{not json\n")
    n = len(open(events).read().splitlines())
    with pytest.raises(InputError, match=f"line {n + 1}"):
        read_review(str(poses), str(broken))
    lines = open(poses).read().splitlines()
    head = lines[0].split(",")
    cells = lines[3].split(",")
    cells[head.index("x")] = "nan"
    bad_poses = tmp_path / "bad.csv"
    bad_poses.write_text("\n".join(lines[:3] + [",".join(cells)] + lines[4:]) + "\n")
    with pytest.raises(InputError, match="line 4"):
        read_review(str(bad_poses), str(events))
    trajectory = tmp_path / "trajectory.csv"
    trajectory.write_text("t,x,y,yaw_deg\n0,1,2,3\n")
    with pytest.raises(InputError, match="looks like a trajectory"):
        read_review(str(trajectory), str(events))
