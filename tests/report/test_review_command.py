"""``tankcd report`` and ``replay --report``: the outputs by suffix, and every refusal exit 3 with one
line and nothing written."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from tests.report.exercise import replay, write_exercise, write_terrain

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    return replay(tmp_path_factory.mktemp("exercise"))


def test_report_writes_geojson_and_czml_of_the_run(run, outputs, tmp_path):
    terrain, poses, events = outputs
    res = run("report", poses, events, "--terrain", terrain, "-o", "x.geojson")
    assert res.exit_code == 0, res.stderr
    doc = json.loads((tmp_path / "x.geojson").read_text())
    n_events = len(open(events).read().splitlines())
    assert sum(f["properties"].get("kind") in ("vehicle", "terrain", "obstacle", "off_terrain", "internal")
               and f["geometry"]["type"] == "Point" for f in doc["features"]) == n_events
    assert {f["properties"]["entity"] for f in doc["features"] if f["geometry"]["type"] == "LineString"} == \
        {"A", "B", "C"}
    assert "report: 3 vehicles" in res.stderr
    res = run("report", poses, events, "--terrain", terrain, "-o", "x.czml")
    assert res.exit_code == 0, res.stderr
    packets = json.loads((tmp_path / "x.czml").read_text())
    assert packets[0]["id"] == "document"


def _one_line_and_nothing(res, tmp_path, before):
    assert res.exit_code == 3, res.output
    assert len(res.stderr.strip().splitlines()) == 1 and res.stderr.startswith("tankcd: error:")
    assert sorted(os.listdir(tmp_path)) == before


def test_refusals_exit_3_with_one_line_and_write_nothing(run, outputs, tmp_path):
    terrain, poses, events = outputs
    before = sorted(os.listdir(tmp_path))
    _one_line_and_nothing(run("report", poses, events, "--terrain", terrain, "-o", "x.pcap"), tmp_path, before)
    _one_line_and_nothing(run("report", poses, events, "--terrain", terrain, "-o", "x.kml"), tmp_path, before)
    _one_line_and_nothing(run("report", poses, events, "--terrain", terrain, "-o", "x.html", "--capture", poses),
                          tmp_path, before)
    # the sample battlefield has no CRS: no longitude and latitude for GIS or Cesium
    for suffix in (".geojson", ".czml"):
        res = run("report", poses, events, "--scene", SAMPLE / "scene.toml", "-o", "x" + suffix)
        _one_line_and_nothing(res, tmp_path, before)
        assert "no CRS" in res.stderr
    # events of another run: another exercise's events against these poses
    other = tmp_path.parent / (tmp_path.name + "-other")
    other.mkdir()
    write_terrain(other / "utm.tif")
    write_exercise(other / "exercise.csv")
    (other / "exercise.csv").write_text((other / "exercise.csv").read_text().replace(",A,", ",D,"))
    from tankcd_cli import api

    api.replay_to_files(str(other / "exercise.csv"), poses=str(other / "p.csv"), events=str(other / "e.jsonl"),
                        terrain=str(other / "utm.tif"))
    res = run("report", poses, other / "e.jsonl", "--terrain", terrain, "-o", "x.geojson")
    _one_line_and_nothing(res, tmp_path, before)
    assert "different runs" in res.stderr


def test_a_report_never_overwrites_an_input(run, outputs, tmp_path):
    terrain, poses, events = outputs
    before = open(poses, "rb").read()
    res = run("report", poses, events, "--terrain", terrain, "-o", poses)
    assert res.exit_code == 2 and open(poses, "rb").read() == before


def test_replay_report_writes_the_report_of_the_run(run, tmp_path):
    write_terrain(tmp_path / "utm.tif")
    write_exercise(tmp_path / "exercise.csv")
    res = run("replay", "exercise.csv", "--terrain", "utm.tif", "--poses", "p.csv", "--events", "e.jsonl",
              "--report", "r.geojson")
    assert res.exit_code == 0, res.stderr
    doc = json.loads((tmp_path / "r.geojson").read_text())
    assert len([f for f in doc["features"] if f["geometry"]["type"] == "Point"]) == \
        len((tmp_path / "e.jsonl").read_text().splitlines())
    res = run("replay", "exercise.csv", "--terrain", "utm.tif", "--poses", "-", "--events", "e2.jsonl",
              "--report", "r2.geojson")
    assert res.exit_code == 2 and not (tmp_path / "e2.jsonl").exists()
    res = run("replay", "exercise.csv", "--terrain", "utm.tif", "--poses", "p3.csv", "--events", "e3.jsonl",
              "--report", "r3.pcap")
    assert res.exit_code == 3 and not (tmp_path / "p3.csv").exists()
    assert "capture" in res.stderr


def test_replay_of_a_capture_reports_its_contacts_into_the_capture(run, tmp_path):
    from tests.report.test_collision_pdus import _is_collision, _records, write_head_on

    capture, tif = write_head_on(tmp_path)
    res = run("replay", capture, "--terrain", tif, "--poses", "p.csv", "--events", "e.jsonl", "--report", "out.pcap")
    assert res.exit_code == 0, res.stderr
    _, original = _records(capture.read_bytes())
    _, written = _records((tmp_path / "out.pcap").read_bytes())
    assert [r for r in written if not _is_collision(r[2])] == original
    vehicle = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()
               if json.loads(line)["kind"] == "vehicle"]
    assert len(vehicle) == 1 and sum(_is_collision(r[2]) for r in written) >= 2
    # the same by tankcd report
    res = run("report", "p.csv", "e.jsonl", "--terrain", tif, "--capture", capture, "-o", "again.pcap")
    assert res.exit_code == 0, res.stderr
    assert (tmp_path / "again.pcap").read_bytes() == (tmp_path / "out.pcap").read_bytes()
    assert "Collision PDUs" in res.stderr
