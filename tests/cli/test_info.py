"""tankcd info: every pair says its order, in text; JSON numbers are numbers; all four kinds of file."""

import json
import os
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from tankcd_cli.cli.main import cli

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A grid store, a mesh store and a tree of the sample data."""
    out = tmp_path_factory.mktemp("info")
    runner = CliRunner()
    for args in (["classify", SAMPLE / "battlefield.asc", "-o", out / "grid.h5"],
                 ["classify", SAMPLE / "battlefield.obj", "-o", out / "mesh.h5"],
                 ["bvh", SAMPLE / "depot.obj", "-o", out / "depot.bvh.h5"]):
        result = runner.invoke(cli, [str(a) for a in args])
        assert result.exit_code == 0, result.output
    return out


def _text(run, path):
    result = run("info", path)
    assert result.exit_code == 0, result.stderr
    return {m[0]: m[1] for m in re.findall(r"^\s*([a-z][a-z0-9 ]*):[ ]+(\S.*)$", result.stdout, re.M)}


def _json(run, path):
    result = run("info", path, "--json")
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


def test_grid_store_pairs_say_their_order(run, files):
    lines = _text(run, files / "grid.h5")
    assert lines["grid posts"] == "161 rows x 241 columns"
    assert lines["tile posts"] == "161 rows x 241 columns"
    assert lines["post spacing"] == "1 m (x) x 1 m (y)"
    assert lines["north west post"] == "x 500000, y 4500160"
    assert lines["extent x"] == "500000 to 500240"
    assert lines["extent y"] == "4500000 to 4500160"
    assert lines["size"] == "0.24 km (x) x 0.16 km (y)"
    assert lines["area flat"] == "56.2%" and lines["area general"] == "35.7%" and lines["area uneven"] == "8.1%"
    assert "size km" not in lines


def test_grid_store_json_numbers_and_shapes(run, files):
    facts = _json(run, files / "grid.h5")
    assert facts["grid_posts"] == {"rows": 161, "columns": 241}
    assert facts["tile_posts"] == {"rows": 161, "columns": 241}
    assert facts["post_spacing"] == [1.0, 1.0] and facts["size_km"] == [0.24, 0.16]
    assert facts["north_west_post"] == [500000.0, 4500160.0]
    shares = [facts[f"area_fraction_{c}"] for c in ("flat", "general", "uneven")]
    assert all(isinstance(s, float) and 0 <= s <= 1 for s in shares)
    assert sum(shares) == pytest.approx(1.0)
    assert round(shares[0], 3) == 0.562
    assert not any(k.startswith("area_") and not k.startswith("area_fraction_") for k in facts)


def test_mesh_store(run, files):
    lines = _text(run, files / "mesh.h5")
    assert lines["class raster cells"] == "300 rows x 449 columns"
    assert lines["dem grid posts"] == "none (an irregular mesh)"
    assert lines["extent x"] == "0 to 240"
    assert lines["area uneven"] == "10.6%"
    facts = _json(run, files / "mesh.h5")
    assert facts["class_raster_cells"] == {"rows": 300, "columns": 449}
    assert isinstance(facts["area_fraction_uneven"], float)


def test_tree_file(run, files):
    lines = _text(run, files / "depot.bvh.h5")
    assert lines["bounds"] == "x -6 to 6, y -4 to 4, z 0 to 6"
    assert lines["nodes per level"] == "1, 2, 4, 8, 16 (from the root down)"
    facts = _json(run, files / "depot.bvh.h5")
    assert facts["bounds"] == {"min": [-6.0, -4.0, 0.0], "max": [6.0, 4.0, 6.0]}


def test_scene(run):
    lines = _text(run, SAMPLE / "scene.toml")  # a label met twice keeps its last value
    assert lines["position"] == "x 500100, y 4500077.5, z 98.5"  # the last obstacle's: the wall
    assert lines["scale"] == "x 1, y 1, z 1"
    assert lines["bounds"] == "x 500096.2402 to 500103.7598, y 4500071.288 to 4500083.712, z 98.5 to 101.5"
    assert lines["on terrain"] == "yes" and lines["fuel drums"] == "yes"
    assert lines["turret still"] == "terrain contact yes, obstacles yes, internal no"
    text = run("info", SAMPLE / "scene.toml").stdout
    assert text.startswith(f"file:                 {SAMPLE / 'scene.toml'}\nkind:                 scene\n")
    assert "kind:               DEM (asc, 161 rows x 241 columns of posts, classified on the fly)\n" in text
    facts = _json(run, SAMPLE / "scene.toml")
    assert facts["obstacles"][1]["position"] == [500100.0, 4500077.5, 98.5]
    assert facts["terrain"]["extent_x"] == [500000.0, 500240.0]


def test_stdin_is_a_usage_error(run):
    result = run("info", "-")
    assert result.exit_code == 2
    assert result.stderr.endswith("Error: Invalid value for 'FILE': info reads a file (a store is read in place, a "
                                  "scene's paths are relative to it), not standard input\n")


def test_trajectory_entities_and_their_vehicles(run, tmp_path):
    path = tmp_path / "two.csv"
    path.write_text("t,entity,x,y,yaw_deg\n0,alpha,500050,4500050,0\n1,alpha,500052,4500050,0\n"
                    "0.5,bravo,500080,4500060,90\n")
    lines = _text(run, path)
    assert lines["kind"] == "trajectory" and lines["skipped"] == "none"  # "rows" is met again per entity
    facts = _json(run, path)
    assert facts["rows"] == 3 and facts["t_first"] == 0.0 and facts["t_last"] == 1.0
    assert [(e["name"], e["rows"], e["t_first"], e["t_last"], e["first_line"], e["last_line"])
            for e in facts["entities"]] == [("alpha", 2, 0.0, 1.0, 2, 3), ("bravo", 1, 0.5, 0.5, 4, 4)]
    scene = tmp_path / "scene.toml"
    scene.write_text(f'[terrain]\npath = "{(SAMPLE / "battlefield.asc").as_posix()}"\n'
                     '[vehicle]\npreset = "t72"\n'
                     '[[entity]]\nid = "bravo"\npreset = "m1"\n')
    facts = json.loads(run("info", path, "--json", "--scene", scene).stdout)
    assert [e["vehicle"] for e in facts["entities"]] == ["[vehicle] t72", "[[entity]] id bravo: m1"]
    assert run("info", SAMPLE / "patrol.csv").stdout.count("\n  patrol:\n") == 1


# --- what replay writes, raw terrains, and what is none of them --------------------------------------

@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """The sample patrol replayed by the command line: events as JSON Lines, poses and events as
    Parquet, the summary as a file; and a fleet of it (fleet.json)."""
    out = tmp_path_factory.mktemp("info_outputs")
    runner = CliRunner()
    scene = SAMPLE / "scene.toml"
    for args in (["replay", SAMPLE / "patrol.csv", "--scene", scene, "--poses", out / "poses.parquet",
                  "--events", out / "events.jsonl", "--summary", out / "summary.json", "-q"],
                 ["replay", SAMPLE / "patrol.csv", "--scene", scene, "--out-dir", out / "fleet",
                  "--out-format", "parquet", "-q"]):
        result = runner.invoke(cli, [str(a) for a in args])
        assert result.exit_code == 0, result.output
    return out


def test_events_jsonl_text_and_json(run, outputs):
    lines = _text(run, outputs / "events.jsonl")
    assert lines["kind"] == "events" and lines["format"] == "JSON Lines"
    assert lines["by kind"] == "obstacle 58, internal 33, terrain 16"
    assert lines["between"] == "2" and lines["between share"] == "1.9%"
    assert lines["obstacles"] == "wall 58"
    assert lines["parts"] == "drum_left 2, drum_right 2, gun 41, hull 31, track_left 13, track_right 13, turret 5"
    facts = _json(run, outputs / "events.jsonl")
    assert facts["by_kind"] == {"obstacle": 58, "internal": 33, "terrain": 16} and facts["events"] == 107
    assert facts["between_fraction"] == pytest.approx(2 / 107, abs=1e-6)


def test_parquet_poses_and_events_text_and_json(run, outputs):
    lines = _text(run, outputs / "fleet" / "patrol.events.parquet")
    assert lines["kind"] == "events (Parquet)" and lines["by kind"] == "obstacle 58, internal 33, terrain 16"
    assert (lines["matcher"], lines["escalate"], lines["attitude tolerance"], lines["mode"], lines["time origin"]) \
        == ("auto", "none", "none", "continuous", "none (relative times)")
    assert lines["crs"] == "local grid (no CRS)"
    text = run("info", outputs / "fleet" / "patrol.events.parquet").stdout
    assert f"\n  wall:\n    role:             obstacle\n    path:             {SAMPLE / 'wall.obj'}\n" in text
    facts = _json(run, outputs / "poses.parquet")
    assert facts["kind"] == "poses (Parquet)" and facts["rows"] == 1144 and facts["row_groups"] == 1
    assert facts["t_first"] == 0.0 and facts["t_last"] == 114.3 and facts["status"] == {"ok": 1144}
    assert [s["role"] for s in facts["sources"]] == ["trajectory", "scene", "obstacle", "obstacle", "terrain"]
    assert all(len(s["sha256"]) == 64 for s in facts["sources"])


def test_summary_and_fleet_json_text_and_json(run, outputs):
    lines = _text(run, outputs / "summary.json")
    assert lines["kind"] == "replay summary" and lines["rows"] == "1144"
    assert lines["collisions"] == "obstacle 57, internal 32, terrain 16" and lines["warnings"] == "none"
    assert _json(run, outputs / "summary.json")["between"] == {"obstacle": 1, "internal": 1, "terrain": 0,
                                                               "off_terrain": 0}
    lines = _text(run, outputs / "fleet" / "fleet.json")
    assert lines["kind"] == "fleet summary (fleet.json)" and lines["ok"] == "1" and lines["failed"] == "0"
    assert lines["failures"] == "none" and lines["ran on"] == "1 process"
    text = run("info", outputs / "fleet" / "fleet.json").stdout
    assert f"results:\n  {SAMPLE / 'patrol.csv'}:\n    status:           ok\n    rows:             1144\n" in text
    facts = _json(run, outputs / "fleet" / "fleet.json")
    assert facts["rows"] == 1144 and facts["results"][0]["poses"].endswith("patrol.poses.parquet")


def test_warnings_are_one_a_line(run, outputs, tmp_path):
    summary = json.loads((outputs / "summary.json").read_text())
    summary["warnings"] = ["patrol.csv: line 7: a warning long enough to stand on its own line", "terrain: another"]
    (tmp_path / "warned.json").write_text(json.dumps(summary))
    text = run("info", tmp_path / "warned.json").stdout
    assert ("\nwarnings:\n  - patrol.csv: line 7: a warning long enough to stand on its own line\n"
            "  - terrain: another\n") in text


def test_raw_terrains_text_and_json(run, tmp_path):
    lines = _text(run, SAMPLE / "battlefield.asc")
    assert lines["kind"] == "DEM raster" and lines["grid posts"] == "161 rows x 241 columns"
    assert lines["post spacing"] == "1 m (x) x 1 m (y)" and lines["nodata share"] == "0.0%"
    assert lines["store"] == ("not classified: a raw terrain, not a store; tankcd classify "
                              f"{SAMPLE / 'battlefield.asc'} -o {SAMPLE / 'battlefield.h5'} makes one "
                              "(replay classifies it on the fly)")
    facts = _json(run, SAMPLE / "battlefield.asc")
    assert facts["extent_x"] == [500000.0, 500240.0] and facts["every_post"] is True
    assert os.listdir(tmp_path) == []  # info wrote nothing (it runs in tmp_path)
    assert not (SAMPLE / "battlefield.h5").exists()
    lines = _text(run, SAMPLE / "battlefield.obj")
    assert lines["kind"] == "terrain mesh" and lines["vertices"] == "38801" and lines["faces"] == "76800"
    assert _json(run, SAMPLE / "depot.obj")["extent_z"] == [0.0, 6.0]


def test_a_heightmap_says_the_options_it_needs(run, tmp_path):
    import numpy as np

    (tmp_path / "hm.r16").write_bytes(np.arange(64 * 64, dtype="<u2").tobytes())
    lines = _text(run, tmp_path / "hm.r16")
    assert lines["kind"] == "heightmap" and lines["grid posts"] == "64 rows x 64 columns"
    assert lines["spacing"] == "--spacing M (required: the file holds no post spacing)"
    assert _json(run, tmp_path / "hm.r16")["extent_value"] == [0.0, 4095.0]


def test_unknown_or_unreadable_files_exit_3_in_one_line(run, tmp_path):
    (tmp_path / "junk.bin").write_bytes(bytes(range(256)))
    (tmp_path / "other.json").write_text('{"hello": 1}\n')
    (tmp_path / "bad.jsonl").write_text('{"step":1,"t":0,"kind":"terrain","a":"hull","b":"terrain"}\nnope\n')
    (tmp_path / "cut.parquet").write_bytes(b"PAR1 cut short")
    for name, what in (("junk.bin", "not a file tankcd reads or writes: not a terrain store, a tree, a scene"),
                       ("other.json", "a JSON file, but not one tankcd writes"),
                       ("bad.jsonl", "line 2: not JSON"),
                       ("cut.parquet", "not a Parquet file pyarrow can read"),
                       ("missing.csv", "no such file")):
        result = run("info", tmp_path / name)
        assert result.exit_code == 3, (name, result.stderr)
        assert result.stderr.count("\n") == 1 and f"{tmp_path / name}: {what}" in result.stderr, result.stderr
        assert result.stdout == ""
    result = run("info", tmp_path)
    assert result.exit_code == 3 and "is a directory" in result.stderr


def test_a_trajectory_is_what_the_input_registry_says(run, tmp_path):
    """info tells a trajectory by the reader's registry (io.trajectory.formats.INPUT_FORMATS), not by a
    list of its own: a Wireshark .cap is a DIS capture, pcap or pcapng by its magic, as replay reads it;
    a .cap holding neither is refused as the capture reader refuses it; and every registered format's
    kind is the one info names."""
    from tankcd_cli.io.trajectory.formats import INPUT_FORMATS, trajectory_format
    from tests.io import captures as C
    from tests.io.test_dis import T0, ecef

    frame = C.ethernet(C.ipv4(C.udp(C.es_dis7(1, 2, 3, ecef(10, 50), (0.1, 0.2, 0.3)))))
    files = {"exercise.cap": (C.pcap([(T0, frame), (T0 + 1, frame)]), "pcap"),
             "merged.cap": (C.pcapng([(1, None, 0)], [(0, T0 * 10**6, frame)]), "pcapng")}
    kinds = {f.name: f.kind for f in INPUT_FORMATS}
    assert set(kinds) == {"csv", "gpx", "pcap", "pcapng"}
    for name, (data, fmt) in files.items():
        (tmp_path / name).write_bytes(data)
        assert trajectory_format(str(tmp_path / name)) == fmt
        facts = json.loads(run("info", tmp_path / name, "--json").stdout)
        assert (facts["kind"], facts["format"], facts["rows"]) == (kinds[fmt], fmt, 2 if fmt == "pcap" else 1)
    (tmp_path / "junk.cap").write_bytes(b"neither capture")
    result = run("info", tmp_path / "junk.cap")
    assert result.exit_code == 3 and "not a pcap or pcapng capture (it starts with bytes 6e 65 69 74" in result.stderr
