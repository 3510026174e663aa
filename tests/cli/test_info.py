"""tankcd info: every pair says its order, in text; JSON numbers are numbers; all four kinds of file."""

import json
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
