"""tankcd report and replay --report: every refusal exit 3 (or 2 for a usage error) with one line on
stderr and nothing written; the writers run by the output's suffix (those tests skip where a
writer's module is not there yet)."""

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from tankcd_cli.cli.main import cli
from tests.replay.scenes import flat, hull_mesh, scene
from tests.report.test_inputs import exercise_rows


def invoke(cwd: Path, *args):
    import os

    here = os.getcwd()
    os.chdir(cwd)
    try:
        return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
    finally:
        os.chdir(here)


@pytest.fixture(scope="module")
def ex(tmp_path_factory):
    """A flat scene without a CRS, an exercise of three vehicles replayed to p.csv and e.jsonl."""
    from tankcd_cli import api

    d = tmp_path_factory.mktemp("review")
    flat(d)
    scene(d, [("wall", [108.0, 5.0, 99.0], [109.0, 15.0, 104.0])], hull_mesh(d))
    (d / "ex.csv").write_text(exercise_rows())
    api.replay_to_files(str(d / "ex.csv"), poses=str(d / "p.csv"), events=str(d / "e.jsonl"),
                        scene=str(d / "scene.toml"))
    return d


def files(d: Path) -> set:
    return {p.name for p in d.iterdir()}


def one_line_error(result, code=3) -> str:
    assert result.exit_code == code, (result.exit_code, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tankcd: error: "), result.stderr
    assert result.stdout == ""
    return lines[0]


@pytest.mark.parametrize("out, extra, match", [
    ("r.txt", (), "unknown output suffix '.txt'"),
    ("r", (), "unknown output suffix '(none)'"),
    ("r.geojson", (), "the terrain has no CRS: GEOJSON"),
    ("r.CZML", (), "the terrain has no CRS: CZML"),
    ("r.pcap", (), "a .pcap review needs --capture"),
    ("r.html", ("--capture", "ex.csv"), "--capture goes with a .pcap output only"),
    ("ex.pcap", ("--capture", "ex.pcap"), "the output is also --capture ex.pcap"),
])
def test_refusals_before_any_work_exit_3_in_one_line_and_write_nothing(ex, out, extra, match):
    shutil.copy(ex / "ex.csv", ex / "ex.pcap")  # a capture's name is all the checks look at
    before = files(ex)
    result = invoke(ex, "report", "p.csv", "e.jsonl", "--scene", "scene.toml", "-o", out, *extra)
    assert match in one_line_error(result)
    assert files(ex) == before


def test_an_output_onto_an_input_is_refused(ex, tmp_path):
    poses = tmp_path / "p.html"  # poses under a name a review could write
    shutil.copy(ex / "p.csv", poses)
    before = poses.read_bytes()
    result = invoke(ex, "report", str(poses), "e.jsonl", "--scene", "scene.toml", "-o", str(poses))
    assert "the output is also POSES" in one_line_error(result)
    assert poses.read_bytes() == before


def test_events_that_disagree_with_the_poses_exit_3_naming_the_event(ex, tmp_path):
    events = [json.loads(line) for line in (ex / "e.jsonl").read_text().splitlines()]
    events[2]["step"] = 99999
    bad = tmp_path / "bad.jsonl"
    bad.write_text("".join(json.dumps(e) + "\n" for e in events))
    out = tmp_path / "r.html"
    result = invoke(ex, "report", "p.csv", str(bad), "--scene", "scene.toml", "-o", str(out))
    line = one_line_error(result)
    assert str(bad) in line and "line 3" in line and "step 99999 is no pose row's step" in line
    assert not out.exists()


def test_missing_inputs_exit_3(ex, tmp_path):
    result = invoke(ex, "report", "nope.csv", "e.jsonl", "--scene", "scene.toml", "-o", str(tmp_path / "r.html"))
    assert "nope.csv: no such file" in one_line_error(result)


@pytest.mark.parametrize("world", [(), ("--scene", "scene.toml", "--terrain", "ground.asc")])
def test_one_world_exactly_is_a_usage_error_otherwise(ex, world):
    result = invoke(ex, "report", "p.csv", "e.jsonl", *world, "-o", "r.html")
    assert result.exit_code == 2 and "give --scene or --terrain" in result.stderr


# --- replay --report ----------------------------------------------------------------------------

@pytest.mark.parametrize("outputs, code, match", [
    (("--events", "e2.jsonl"), 2, "give --poses FILE and --events FILE"),  # poses to standard output
    (("--poses", "p2.csv"), 2, "give --poses FILE and --events FILE"),  # events not written
    (("--poses", "p2.csv", "--events", "e2.jsonl"), 3, "trajectory is no capture"),
])
def test_replay_report_refusals_before_the_replay(ex, outputs, code, match):
    before = files(ex)
    result = invoke(ex, "replay", "ex.csv", "--scene", "scene.toml", *outputs, "--report", "r2.pcap")
    assert result.exit_code == code, result.stderr
    assert match in result.stderr and result.stdout == ""
    assert files(ex) == before


@pytest.mark.parametrize("out, match", [("r2.txt", "unknown output suffix"),
                                        ("r2.geojson", "the terrain has no CRS"),
                                        ("ex.html", None)])
def test_replay_report_checks_the_review_before_replaying(ex, out, match):
    if match is None:  # onto an input: the replay's own clash check (a usage error)
        shutil.copy(ex / "ex.csv", ex / "ex.html")
        result = invoke(ex, "replay", "ex.html", "--format", "csv", "--scene", "scene.toml", "--poses", "p2.csv",
                        "--events", "e2.jsonl", "--report", "ex.html")
        assert result.exit_code == 2 and "--report ex.html is also TRAJECTORY" in result.stderr
        return
    before = files(ex)
    result = invoke(ex, "replay", "ex.csv", "--scene", "scene.toml", "--poses", "p2.csv", "--events", "e2.jsonl",
                    "--report", out)
    assert match in one_line_error(result)
    assert files(ex) == before


# --- the writers, by suffix (each skips until its module is there) -----------------------------

def _utm_scene(d: Path):
    """The exercise again on a flat GeoTIFF in UTM 33N (a terrain with a CRS)."""
    rasterio = pytest.importorskip("rasterio")
    pytest.importorskip("pyproj")
    import numpy as np
    from rasterio.transform import from_origin

    x0, yn = 400000.0, 5001000.0
    with rasterio.open(d / "utm.tif", "w", driver="GTiff", height=60, width=160, count=1, dtype="float32",
                       crs="EPSG:32633", transform=from_origin(x0 - 0.5, yn + 0.5, 1.0, 1.0)) as dst:
        dst.write(np.full((60, 160), 100.0, np.float32), 1)
    rows = ["t,entity,x,y,yaw_deg"] + [line for line in exercise_rows().splitlines()[1:]]
    shifted = []
    for line in rows[1:]:
        t, e, x, y, yaw = line.split(",")
        shifted.append(f"{t},{e},{x0 + float(x)},{yn - 60 + float(y)},{yaw}")
    (d / "utm.csv").write_text("\n".join(rows[:1] + shifted) + "\n")


@pytest.mark.parametrize("suffix, module", [(".geojson", "geojson"), (".czml", "czml")])
def test_geojson_and_czml_through_the_command(tmp_path, suffix, module):
    pytest.importorskip(f"tankcd_cli.report.{module}")
    _utm_scene(tmp_path)
    result = invoke(tmp_path, "replay", "utm.csv", "--terrain", "utm.tif", "--poses", "p.csv", "--events",
                    "e.jsonl", "-q")
    assert result.exit_code == 0, result.stderr
    out = tmp_path / f"r{suffix}"
    result = invoke(tmp_path, "report", "p.csv", "e.jsonl", "--terrain", "utm.tif", "-o", out.name)
    assert result.exit_code == 0, result.stderr
    doc = json.loads(out.read_text())
    if suffix == ".geojson":
        assert doc["type"] == "FeatureCollection" and len(doc["features"]) > 3
    else:
        assert doc[0]["id"] == "document"
    assert "report: 3 vehicles" in result.stderr and f"wrote {out.name}" in result.stderr
    again = tmp_path / f"again{suffix}"  # replay --report writes the same
    result = invoke(tmp_path, "replay", "utm.csv", "--terrain", "utm.tif", "--poses", "p2.csv", "--events",
                    "e2.jsonl", "--report", again.name)
    assert result.exit_code == 0, result.stderr
    assert again.exists()


def test_the_page_through_the_command_and_the_api(ex, tmp_path):
    pytest.importorskip("tankcd_cli.report.page")
    pytest.importorskip("tankcd_cli.report.background")
    from tankcd_cli import api

    out = tmp_path / "r.HTML"
    result = invoke(ex, "report", "p.csv", "e.jsonl", "--scene", "scene.toml", "-o", str(out))
    assert result.exit_code == 0, result.stderr
    assert out.read_text(encoding="utf-8").lstrip().lower().startswith("<!doctype html")
    got = api.report(str(ex / "p.csv"), str(ex / "e.jsonl"), str(tmp_path / "r2.html"), scene=str(ex / "scene.toml"))
    events = len((ex / "e.jsonl").read_text().splitlines())
    assert got == {"output": str(tmp_path / "r2.html"), "vehicles": 3, "events": events,
                   "bytes": (tmp_path / "r2.html").stat().st_size}


def test_collision_pdus_for_a_replayed_capture(tmp_path):
    pytest.importorskip("tankcd_cli.report.collision_pdus")
    rasterio = pytest.importorskip("rasterio")  # noqa: F841
    from tests.replay.test_windows import _capture_exercise, _utm_ground

    x0, yn = _utm_ground(tmp_path)
    _capture_exercise(tmp_path / "ex.pcap", x0, yn)
    result = invoke(tmp_path, "replay", "ex.pcap", "--terrain", "flat.tif", "--poses", "p.csv", "--events",
                    "e.jsonl", "--report", "r.pcap")
    assert result.exit_code == 0, result.stderr
    original = (tmp_path / "ex.pcap").read_bytes()
    written = (tmp_path / "r.pcap").read_bytes()
    assert len(written) > len(original) and written[:24] == original[:24]  # the capture's header, more packets
    result = invoke(tmp_path, "report", "p.csv", "e.jsonl", "--terrain", "flat.tif", "--capture", "ex.pcap",
                    "-o", "r2.pcap")
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "r2.pcap").read_bytes() == written
