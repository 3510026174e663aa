"""tankcd replay over a terrain: pose rows for every trajectory row, bad rows named exactly."""

import csv
import json
import io
import subprocess
import sys
from pathlib import Path

import numpy as np

from tankcd_cli.names import KEY_POINT_MATCHERS
import pytest

from tankcd_cli.io.poses_csv import COLUMNS

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    from click.testing import CliRunner

    from tankcd_cli.cli.main import cli

    out = tmp_path_factory.mktemp("replay") / "bf.h5"
    assert CliRunner().invoke(cli, ["classify", str(SAMPLE / "battlefield.asc"), "-o", str(out)]).exit_code == 0
    return out


def trajectory(n=50, x0=500010.0, y0=4500080.0, extra=""):
    rows = ["t,x,y,yaw_deg" + (",note" if extra else "")]
    for k in range(n):
        rows.append(f"{k * 0.5},{x0 + 4.4 * k},{y0 + 0.5 * k},{(k * 17.0) % 360 - 180}" + (f",{extra}" if extra else ""))
    return "\n".join(rows) + "\n"


def test_replay_writes_one_pose_per_row(run, store):
    result = run("replay", "-", "--terrain", store, input=trajectory())
    assert result.exit_code == 0, result.stderr
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert len(rows) == 50
    assert list(rows[0].keys()) == list(COLUMNS)
    assert [int(r["step"]) for r in rows] == list(range(50))
    for r in rows:
        assert r["status"] == "ok" and r["region"] in ("flat", "general", "uneven")
        # auto's key-point matcher, or the reference where the certificate sent the pose to it
        assert r["matcher"].removesuffix("+reference") in KEY_POINT_MATCHERS
        q = np.array([float(r[k]) for k in ("qw", "qx", "qy", "qz")])
        assert q[0] >= 0 and abs(np.linalg.norm(q) - 1) < 1e-7
        assert np.isfinite([float(r[k]) for k in ("z", "roll_deg", "pitch_deg", "penetration", "gap")]).all()
    assert "replay: 50 rows" in result.stderr


def test_replay_matcher_choice_and_file_output(run, store, tmp_path):
    (tmp_path / "t.csv").write_text(trajectory(extra="free text"))
    result = run("replay", "t.csv", "--terrain", store, "--matcher", "reference", "--poses", "p.csv")
    assert result.exit_code == 0, result.stderr
    rows = list(csv.DictReader(open(tmp_path / "p.csv")))
    assert {r["matcher"] for r in rows} == {"reference"}
    assert max(float(r["penetration"]) for r in rows) < 1e-6


def test_off_terrain_rows_say_so(run, store):
    result = run("replay", "-", "--terrain", store, input="t,x,y,yaw_deg\n0,500010,4500080,0\n1,0,0,0\n")
    assert result.exit_code == 0
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert rows[1]["status"] == "off" and rows[1]["z"] == "" and rows[1]["qw"] == ""
    assert rows[0]["status"] == "ok"


@pytest.mark.parametrize("text,fragment", [
    ("", "file is empty"),
    ("t,x,yaw_deg\n0,1,2\n", "lacks the required column y"),
    ("t,x,y,yaw_deg\n0,500010,4500080,0\n1,500011,4500080\n", "line 3: expected 4 columns"),
    ("t,x,y,yaw_deg\n0,500010,4500080,0\n1,abc,4500080,0\n", "line 3 column x: not a number: 'abc'"),
    ("t,x,y,yaw_deg\n0,500010,4500080,nan\n", "line 2 column yaw_deg: non-finite"),
    ("t,x,y,yaw_deg\n1,500010,4500080,0\n0.5,500010,4500080,0\n", "line 3 column t: time goes back"),
    ("t,x,t,y,yaw_deg\n0,1,0,2,3\n", "column t appears twice"),
])
def test_bad_trajectories_exit_3_naming_line_and_column(run, store, text, fragment):
    result = run("replay", "-", "--terrain", store, input=text)
    assert result.exit_code == 3
    assert "<stdin>" in result.stderr and fragment in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_bom_crlf_and_blank_lines(run, store):
    text = "\ufefft,x,y,yaw_deg\r\n0,500010,4500080,0\r\n\r\n1,500012,4500080,0\r\n"
    result = run("replay", "-", "--terrain", store, input=text.encode("utf-8"))
    assert result.exit_code == 0, result.stderr
    assert len(result.stdout.strip().splitlines()) == 3


def test_bad_row_leaves_no_poses_file(run, store, tmp_path):
    (tmp_path / "t.csv").write_text(trajectory() + "99,oops,1,1\n")
    result = run("replay", "t.csv", "--terrain", store, "--poses", "p.csv")
    assert result.exit_code == 3 and "line 52" in result.stderr
    assert not (tmp_path / "p.csv").exists()


def test_terrain_classified_on_the_fly(run):
    result = run("replay", "-", "--terrain", SAMPLE / "battlefield.obj", input="t,x,y,yaw_deg\n0,20,80,45\n")
    assert result.exit_code == 0, result.stderr
    assert len(result.stdout.strip().splitlines()) == 2


def test_pipeline_into_head_exits_quietly(store, tmp_path):
    (tmp_path / "t.csv").write_text(trajectory(n=3000))
    proc = subprocess.run(f"{sys.executable} -m tankcd_cli replay {tmp_path / 't.csv'} --terrain {store} | head -2",
                          shell=True, capture_output=True, text=True)
    assert proc.stdout.count("\n") == 2
    assert "Traceback" not in proc.stderr and "Error" not in proc.stderr


# options that only make sense with another: usage errors naming both (issue 22)
FLEET = "fleet mode (--out-dir, or several trajectories)"
ESCALATION = "escalation (--escalate, or --matcher auto without --no-escalate)"
FLEET_NEEDS = "it sets how a fleet runs, and a fleet writes one poses and one events file per trajectory there"


@pytest.mark.parametrize("args,message", [
    (["--png-colour", "matcher"], "--png-colour needs --png: it colours the path --png draws"),
    (["--allow-off-terrain"], "--allow-off-terrain needs --fail-on-collision: it keeps rows off the terrain from "
                              "failing the run"),
    (["--matcher", "two_point", "--tolerance", "0.1"],
     f"--tolerance needs {ESCALATION}: it is the certificate's tolerance, which only escalation checks"),
    (["--no-escalate", "--tolerance", "0.1"],
     f"--tolerance needs {ESCALATION}: it is the certificate's tolerance, which only escalation checks"),
    (["--no-escalate", "--attitude-tolerance", "0.3"],
     f"--attitude-tolerance needs {ESCALATION}: it is the certificate's tolerance, which only escalation checks"),
    (["--jobs", "2"], "--jobs needs --out-dir or --window-seconds: it sets how many processes run a fleet's "
                      "trajectories or an exercise's time windows"),
    (["--scheduler", "tcp://localhost:8786"], "--scheduler needs --out-dir or --window-seconds: it runs a fleet's "
                                              "trajectories or an exercise's time windows on the cluster"),
    (["--out-dir", "o", "--window-seconds", "60"],
     f"--window-seconds does not apply with {FLEET}: it cuts one exercise into time windows, written into --poses "
     "and --events"),
    (["--window-seconds", "60", "--png", "a.png"],
     "--png does not apply with --window-seconds: it draws a replay run in one piece"),
    (["--split-lines", "5000"], f"--split-lines needs --out-dir: {FLEET_NEEDS}"),
    (["--out-format", "parquet"], "--out-format needs --out-dir: it sets the format of the files a fleet writes "
                                  "there (one replay writes Parquet to --poses and --events ending in .parquet)"),
    (["--out-dir", "o", "--poses", "p.csv"],
     f"--poses does not apply with {FLEET}: a fleet writes OUT/NAME.poses.csv for each trajectory (.parquet with "
     "--out-format parquet)"),
    (["--out-dir", "o", "--events", "e.jsonl"],
     f"--events does not apply with {FLEET}: a fleet writes OUT/NAME.events.jsonl for each trajectory (.parquet "
     "with --out-format parquet)"),
    (["--out-dir", "o", "--cache"],
     f"--cache does not apply with {FLEET}: a fleet does not save its terrain beside it (classify it first with "
     "tankcd classify)"),
    (["--cache"], "--cache does not apply to a store (--terrain {store}): it saves a terrain classified on the "
                  "fly as a store"),
    (["--up", "y"], "--up does not apply to a store (--terrain {store}): a store's terrain was turned z-up when it "
                    "was classified"),
    (["--png", "-"], "--poses and --png both go to standard output (-): give one of them a file"),
])
def test_options_that_cannot_apply_are_usage_errors(run, store, tmp_path, args, message):
    (tmp_path / "t.csv").write_text(trajectory(n=3))
    result = run("replay", "t.csv", "--terrain", store, *args)
    assert result.exit_code == 2, result.stderr
    assert result.stderr.endswith(f"Error: {message.format(store=store)}\n"), result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv"]


def test_scene_options_that_cannot_apply_are_usage_errors(run, store, tmp_path):
    (tmp_path / "t.csv").write_text(trajectory(n=3))
    up = run("replay", "t.csv", "--scene", SAMPLE / "scene.toml", "--up", "y")
    assert up.exit_code == 2
    assert up.stderr.endswith("Error: --up does not apply with --scene: the scene's [terrain] up key decides\n")
    (tmp_path / "s.toml").write_text(f'[terrain]\npath = "{store}"\n')
    cache = run("replay", "t.csv", "--scene", "s.toml", "--cache")
    assert cache.exit_code == 2
    assert cache.stderr.endswith(f"Error: --cache does not apply to a store (the scene's terrain {store}): it saves "
                                 "a terrain classified on the fly as a store\n")


def test_the_options_work_with_what_they_need(run, store, tmp_path):
    (tmp_path / "t.csv").write_text(trajectory(n=3))
    result = run("replay", "t.csv", "--terrain", store, "--png", "m.png", "--png-colour", "matcher", "--poses",
                 "p.csv", "--fail-on-collision", "--allow-off-terrain", "--escalate", "--matcher", "two_point",
                 "--tolerance", "0.05")
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "m.png").exists() and (tmp_path / "p.csv").exists()


def test_summary_prints_under_quiet(run, store):
    result = run("-q", "replay", "-", "--terrain", store, "--summary", input=trajectory(n=3))
    assert result.exit_code == 0
    assert json.loads(result.stderr)["rows"] == 3


def test_a_missing_terrain_store_is_no_such_file(run, tmp_path):
    (tmp_path / "t.csv").write_text(trajectory(n=3))
    result = run("replay", "t.csv", "--terrain", "missing.h5")
    assert result.exit_code == 3
    assert result.stderr == "tankcd: error: missing.h5: no such file\n"


@pytest.mark.parametrize("option", ["--window-seconds", "--tolerance", "--attitude-tolerance"])
@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "0", "-2", "1e400"])
def test_numbers_that_are_no_length_are_bad_input_naming_the_option(run, store, tmp_path, option, value):
    # NaN and infinity pass click's ranges: once a crash (exit 4) deep in the windows' planning
    (tmp_path / "t.csv").write_text("t,x,y,yaw_deg\n0,500100,4500100,0\n")
    result = run("replay", tmp_path / "t.csv", "--terrain", store, option, value, "--poses", tmp_path / "p.csv")
    if option != "--window-seconds" and value in ("0", "-2", "-inf"):
        assert result.exit_code == 2  # their range, as before: a usage error
        return
    assert result.exit_code == 3, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"tankcd: error: {option}: ") and "positive finite" in lines[0]
    assert not (tmp_path / "p.csv").exists()


def test_the_api_refuses_windows_of_no_length(store, tmp_path):
    from tankcd_cli import api

    (tmp_path / "t.csv").write_text("t,x,y,yaw_deg\n0,500100,4500100,0\n")
    for value in (float("nan"), float("inf"), 0.0, -1.0):
        with pytest.raises(ValueError, match="positive finite"):
            api.replay_windows(str(tmp_path / "t.csv"), str(tmp_path / "p.csv"), terrain=str(store),
                               window_seconds=value)
