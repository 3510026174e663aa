"""Fleets: many trajectories in parallel processes and on a real (local) Dask cluster."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.replay.fleet import expand_trajectories, plan_tasks

SAMPLE = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "sample_data")


def _trajectory(path, rows, seed):
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0, 0.03, rows))
    x = 500_005 + np.abs((500_120 + np.cumsum(0.5 * np.cos(heading)) - 500_005) % 220 - 110)
    y = 4_500_005 + np.abs((4_500_080 + np.cumsum(0.5 * np.sin(heading)) - 4_500_005) % 150 - 75)
    t = np.arange(rows) * 0.1
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg,turret_deg,gun_deg\n")
        np.savetxt(fh, np.column_stack([t, x, y, np.degrees(heading), (t * 12) % 360 - 180, np.full(rows, -5.0)]),
                   fmt="%.3f", delimiter=",")
    return path


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fleet")
    for name in ("battlefield.asc", "depot.obj", "wall.obj", "scene.toml"):
        shutil.copy(os.path.join(SAMPLE, name), tmp / name)
    (tmp / "runs").mkdir()
    paths = [_trajectory(tmp / "runs" / f"run{k:02d}.csv", 6000, k) for k in range(8)]
    # the reference: each trajectory replayed alone by the single-trajectory command
    ref = tmp / "alone"
    ref.mkdir()
    for p in paths:
        stem = p.stem
        subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "replay", p, "--scene", tmp / "scene.toml", "--poses",
                        ref / f"{stem}.poses.csv", "--events", ref / f"{stem}.events.jsonl", "--cache"], check=True)
    return tmp, paths, ref


def _same_as_alone(out, ref, names):
    for name in names:
        for suffix in (".poses.csv", ".events.jsonl"):
            assert (out / f"{name}{suffix}").read_bytes() == (ref / f"{name}{suffix}").read_bytes(), name + suffix


def test_expand_paths_globs_and_lists(tmp_path):
    for name in ("a.csv", "b.csv", "c.txt"):
        (tmp_path / name).write_text("t,x,y,yaw_deg\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "a.csv").write_text("t,x,y,yaw_deg\n")
    (tmp_path / "list.txt").write_text("# the runs\nsub/a.csv\n\nb.csv\n")
    got = expand_trajectories([str(tmp_path / "*.csv"), "@" + str(tmp_path / "list.txt"), str(tmp_path / "a.csv")])
    assert got == [str(tmp_path / "a.csv"), str(tmp_path / "b.csv"), str(tmp_path / "sub" / "a.csv")]
    tasks = plan_tasks(got, str(tmp_path / "out"))
    names = [os.path.basename(t.poses) for t in tasks]
    assert names == [f"{tmp_path.name}__a.poses.csv", "b.poses.csv", "sub__a.poses.csv"]
    with pytest.raises(InputError, match="matches no file"):
        expand_trajectories([str(tmp_path / "*.nothing")])
    with pytest.raises(InputError, match="cannot read the list"):
        expand_trajectories(["@" + str(tmp_path / "missing.txt")])


@pytest.mark.parametrize("jobs", [1, 2])
def test_fleet_in_processes_matches_single_runs_and_survives_a_bad_file(fleet, jobs, tmp_path):
    tmp, paths, ref = fleet
    bad = tmp_path / "broken.csv"
    bad.write_text(paths[0].read_text() + "1e9,nan,1,2,3,4\n")
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "tankcd_cli", "replay", str(tmp / "runs" / "*.csv"), bad,
                           "--scene", tmp / "scene.toml", "--out-dir", out, "--jobs", str(jobs)],
                          capture_output=True, text=True)
    assert proc.returncode == 3, proc.stderr  # something failed: the exit code says so
    assert "broken.csv: line 6002" in proc.stderr
    _same_as_alone(out, ref, [p.stem for p in paths])
    assert not (out / "broken.poses.csv").exists() and not (out / "broken.events.jsonl").exists()
    summary = json.loads((out / "fleet.json").read_text())
    assert summary["ok"] == len(paths) and summary["failed"] == 1 and summary["rows"] == 6000 * len(paths)
    assert summary["failures"][0]["trajectory"].endswith("broken.csv")
    assert len({r["pid"] for r in summary["results"]}) == jobs  # the work really was spread


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
@pytest.mark.parametrize("final_newline", [True, False])
def test_split_parts_read_as_the_whole_file(tmp_path, newline, final_newline):
    from tankcd_cli.io.trajectory import read_trajectory, split_trajectory

    rows = [f"{0.1 * k:.1f},{500_010 + k * 0.01:.3f},4500010.000,{k % 360 - 180.0}" for k in range(2500)]
    for k in (0, 7, 999, 1000, 1001, 2400):  # blank lines, also right at the cuts
        rows.insert(k, " " if k % 2 else "")
    path = tmp_path / "t.csv"
    path.write_bytes(("\n\nt,x,y,yaw_deg" + newline + newline.join(rows) + (newline if final_newline else "")).encode())
    whole = list(read_trajectory(str(path), chunk_rows=700))
    for lines in (1000, 1001, 333, 10_000):
        parts = split_trajectory(str(path), lines)
        assert sum(p.rows for p in parts) == 2500
        got = [c for p in parts for c in read_trajectory(str(path), chunk_rows=700, part=p)]
        for name in ("step", "t", "x", "yaw_deg"):
            np.testing.assert_array_equal(np.concatenate([getattr(c, name) for c in got]),
                                          np.concatenate([getattr(c, name) for c in whole]))
        firsts = {c.first_line for c in whole}
        assert {c.first_line for c in got} >= {min(firsts)}


def test_an_exercise_is_not_cut_into_parts(fleet, tmp_path):
    # six vehicles milling about one small square: parts cut by lines would lose the contacts between
    # vehicles whose rows straddle a cut and report again those going on across it
    tmp, _, _ = fleet
    rng = np.random.default_rng(3)
    pos = rng.uniform([500_080, 4_500_040], [500_120, 4_500_080], (6, 2))
    yaw = rng.uniform(0, 360, 6)
    with open(tmp_path / "ex.csv", "w") as fh:
        fh.write("t,entity,x,y,yaw_deg\n")
        for k in range(401):
            fh.writelines(f"{0.5 * k:.1f},V{e},{pos[e, 0]:.4f},{pos[e, 1]:.4f},{yaw[e]:.4f}\n" for e in range(6))
            yaw += rng.normal(0, 10, 6)
            pos = np.clip(pos + 2 * np.c_[np.cos(np.radians(yaw)), np.sin(np.radians(yaw))],
                          [500_060, 4_500_030], [500_140, 4_500_090])
    base = [sys.executable, "-m", "tankcd_cli", "-q", "replay", tmp_path / "ex.csv", "--terrain", tmp / "battlefield.asc"]
    subprocess.run(base + ["--poses", tmp_path / "ex.poses.csv", "--events", tmp_path / "ex.events.jsonl"], check=True)
    subprocess.run(base + ["--out-dir", tmp_path / "out", "--split-lines", "1000", "--jobs", "2"], check=True)
    _same_as_alone(tmp_path / "out", tmp_path, ["ex"])
    assert sum('"kind":"vehicle"' in line for line in (tmp_path / "ex.events.jsonl").open()) >= 10
    assert "parts" not in json.loads((tmp_path / "out" / "fleet.json").read_text())["results"][0]


def test_a_split_trajectory_joins_into_the_single_run_and_names_errors_by_file_line(fleet, tmp_path):
    tmp, paths, ref = fleet
    args = [sys.executable, "-m", "tankcd_cli", "replay", "--scene", tmp / "scene.toml", "--jobs", "2",
            "--split-lines", "1000"]
    out = tmp_path / "out"
    proc = subprocess.run(args + [paths[0], paths[1], "--out-dir", out], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    _same_as_alone(out, ref, [paths[0].stem, paths[1].stem])
    summary = json.loads((out / "fleet.json").read_text())
    assert [r["parts"] for r in summary["results"]] == [6, 6] and not (out / ".parts").exists()
    # time going back exactly at a cut, and a bad cell inside a later part: the same errors as a lone run
    lines = paths[2].read_text().splitlines(keepends=True)
    back = lines[:]
    back[2001] = "0.5" + back[2001][back[2001].index(","):]  # line 2002: the first row of the third part
    bad = lines[:]
    bad[3500] = bad[3500].replace(",", ",x", 1)
    for name, text in (("back.csv", back), ("bad.csv", bad)):
        (tmp_path / name).write_text("".join(text))
        alone = subprocess.run([sys.executable, "-m", "tankcd_cli", "replay", tmp_path / name, "--scene",
                                tmp / "scene.toml", "--poses", tmp_path / "alone.csv"], capture_output=True, text=True)
        split = subprocess.run(args + [tmp_path / name, "--out-dir", tmp_path / f"o-{name}"], capture_output=True,
                               text=True)
        assert alone.returncode == split.returncode == 3
        assert alone.stderr.strip().splitlines()[-1] in split.stderr, (alone.stderr, split.stderr)
        assert not list((tmp_path / f"o-{name}").glob("*.csv")) and not (tmp_path / f"o-{name}" / ".parts").exists()


dask = pytest.importorskip("distributed")


def test_dask_cluster_with_a_worker_killed_midway(fleet, tmp_path):
    tmp, paths, ref = fleet
    from tests.conftest import start_dask_cluster, stop_processes

    address, workers, procs = start_dask_cluster(tmp_path)
    try:
        out = tmp_path / "out"
        run = subprocess.Popen([sys.executable, "-m", "tankcd_cli", "replay", str(tmp / "runs" / "*.csv"),
                                "--scene", tmp / "scene.toml", "--out-dir", out, "--scheduler", address],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        # kill one worker as soon as the first trajectory is done: the others are queued or running
        deadline = time.time() + 120
        while time.time() < deadline and not (out.exists() and list(out.glob("*.poses.csv"))):
            time.sleep(0.05)
        os.kill(workers[0].pid, signal.SIGKILL)
        done_at_kill = len(list(out.glob("*.poses.csv")))
        assert done_at_kill < len(paths)  # the kill really came in the middle
        stdout, stderr = run.communicate(timeout=300)
        assert run.returncode == 0, stderr
        _same_as_alone(out, ref, [p.stem for p in paths])
        summary = json.loads((out / "fleet.json").read_text())
        assert summary["ok"] == len(paths) and summary["rows"] == 6000 * len(paths)
        assert sorted(r["trajectory"] for r in summary["results"]) == sorted(str(p) for p in paths)  # none twice
    finally:
        stop_processes(procs)


def test_outputs_are_never_inputs_a_second_fleet_run_skips_them(run, tmp_path):
    from pathlib import Path

    sample = Path(__file__).resolve().parents[2] / "sample_data"
    lines = (sample / "patrol.csv").read_text().splitlines()[:13]
    for name in ("a", "b"):
        (tmp_path / f"{name}.csv").write_text("\n".join(lines) + "\n")
    first = run("replay", "*.csv", "--scene", sample / "scene.toml", "--out-dir", ".", "--jobs", "1")
    assert first.exit_code == 0, first.stderr
    second = run("replay", "*.csv", "--scene", sample / "scene.toml", "--out-dir", ".", "--jobs", "1", "--summary")
    assert second.exit_code == 0, second.stderr
    assert "skipped 2 files tankcd wrote" in second.stderr
    import json

    summary = json.loads(second.stderr.strip().splitlines()[-1])
    assert summary["trajectories"] == 2 and summary["rows"] == 24


def _ends_in_contact(path):
    """Two vehicles, B sliding sideways into A until the file's last rows: their contact begins at
    6.5 s, in the last 2 s window (6 to 8 s), which closes only after the last chunk."""
    rows = []
    for k in range(15):
        t = 0.5 * k
        rows.append((t, "A", 30.0, 20.0, 0.0))
        rows.append((t, "B", 30.0, round(3.46 + 20 + 2 * (6.5 - t), 4), 0.0))
    path.write_text("t,entity,x,y,yaw_deg\n" + "".join(f"{t},{e},{x},{y},{yaw}\n" for t, e, x, y, yaw in sorted(rows)))
    return path


@pytest.fixture
def flat_scene(tmp_path):
    from tests.conftest import write_asc

    write_asc(tmp_path / "flat.asc", np.full((80, 160), 100.0))
    (tmp_path / "scene.toml").write_text('[terrain]\npath = "flat.asc"\n\n[vehicle]\npreset = "t72"\n'
                                         'fuel_drums = false\n')
    return tmp_path / "scene.toml"


@pytest.mark.filterwarnings("ignore:.*would drive sideways")
@pytest.mark.parametrize("out_format", ["csv", "parquet"])
def test_a_fleet_whose_exercise_ends_in_a_contact_finishes(flat_scene, tmp_path, out_format):
    # the vehicles' last contact comes after the last chunk (the pipeline yields it without one):
    # the fleet's task once took its length and failed (exit 4, TypeError)
    if out_format == "parquet":
        pytest.importorskip("pyarrow")
    from tankcd_cli import api

    ex = _ends_in_contact(tmp_path / "ex.csv")
    other = _ends_in_contact(tmp_path / "other.csv")
    fleet = api.replay_fleet([str(ex), str(other)], str(tmp_path / "out"), scene=str(flat_scene), jobs=1,
                             out_format=out_format)
    assert fleet.failed == 0 and fleet.ok == 2 and fleet.vehicle_contacts == 2, fleet.failures
    first = fleet.results[0]
    assert (first.first_line, first.t_first, first.t_last) == (2, 0.0, 7.0)
    alone = api.replay_to_files(str(ex), str(tmp_path / "p.csv"), str(tmp_path / "e.jsonl"), scene=str(flat_scene))
    assert first.summary.vehicle_contacts == alone.vehicle_contacts == 1
    # every trajectory's warnings, each once, in fleet.json too
    assert fleet.warnings == first.summary.warnings + fleet.results[1].summary.warnings
    assert len(fleet.warnings) == 2 and all("drive sideways" in w for w in fleet.warnings)
    assert json.loads((tmp_path / "out" / "fleet.json").read_text())["warnings"] == fleet.warnings
    if out_format == "csv":
        assert (tmp_path / "out" / "ex.events.jsonl").read_bytes() == (tmp_path / "e.jsonl").read_bytes()


@pytest.mark.filterwarnings("ignore:.*would drive sideways")
def test_minus_v_shows_the_traceback_a_fleet_worker_formatted(flat_scene, tmp_path, monkeypatch):
    # an internal error inside forked workers: exit 4, the one-line error, and under -v the worker's
    # own traceback (formatted there: the frames that raised); without -v none
    from click.testing import CliRunner

    from tankcd_cli.cli.main import cli
    from tankcd_cli.replay import fleet as fleet_module

    def broken(*args, **kwargs):
        raise ZeroDivisionError("deep in the replay")

    monkeypatch.setattr(fleet_module, "run_replay", broken)
    paths = [_ends_in_contact(tmp_path / f"{name}.csv") for name in ("a", "b")]
    for verbose in ([], ["-v"]):
        result = CliRunner().invoke(cli, [*verbose, "replay", *map(str, paths), "--scene", str(flat_scene),
                                          "--out-dir", str(tmp_path / "out"), "--jobs", "2"], catch_exceptions=False)
        assert result.exit_code == 4, result.stderr
        assert "tankcd: error: ZeroDivisionError: deep in the replay" in result.stderr
        shown = "Traceback (most recent call last)" in result.stderr
        assert shown == bool(verbose), result.stderr
        if verbose:
            assert "in broken" in result.stderr and result.stderr.count("Traceback") == 2
            assert "the traceback in its worker (pid" in result.stderr


def test_minus_v_shows_the_traceback_of_an_internal_error(flat_scene, tmp_path, monkeypatch):
    from click.testing import CliRunner

    from tankcd_cli.cli.main import cli
    from tankcd_cli.replay import run as run_module

    def broken(*args, **kwargs):
        raise ZeroDivisionError("deep in the replay")

    monkeypatch.setattr(run_module, "run_replay", broken)
    path = _ends_in_contact(tmp_path / "a.csv")
    for args in (["-v", "replay", str(path)], ["replay", str(path), "-v"], ["replay", str(path)]):
        result = CliRunner().invoke(cli, [*args, "--scene", str(flat_scene), "--poses", str(tmp_path / "p.csv")],
                                    catch_exceptions=False)
        assert result.exit_code == 4
        assert "internal error: ZeroDivisionError: deep in the replay" in result.stderr
        assert ("in broken" in result.stderr) == ("-v" in args), result.stderr


def test_a_split_trajectorys_summary_is_built_from_its_parts_counts_as_one_run(flat_scene, tmp_path):
    # a drive that leaves the terrain, cut into parts of 1000 lines: the joined summary's counts are
    # the run in one piece's (built the same way, from counts), and so is a summary's own round trip
    import dataclasses

    from tankcd_cli import api
    from tankcd_cli.replay.records import ReplayTally
    from tankcd_cli.replay.run import summary_of

    n = 2600
    t = np.arange(n) * 0.1
    x = 10 + 0.06 * np.arange(n)  # 10 m to 166 m: the last rows off the 160 m ground
    with open(tmp_path / "drive.csv", "w") as fh:
        fh.write("t,x,y,yaw_deg\n")
        np.savetxt(fh, np.column_stack([t, x, np.full(n, 40.0), np.zeros(n)]), fmt="%.3f", delimiter=",")
    fleet = api.replay_fleet([str(tmp_path / "drive.csv")], str(tmp_path / "out"), scene=str(flat_scene), jobs=1,
                             split_lines=1000)
    joined = fleet.results[0]
    assert joined.parts == 3 and joined.status == "ok"
    alone = api.replay_to_files(str(tmp_path / "drive.csv"), None, None, scene=str(flat_scene))
    assert alone.off_terrain > 0 and alone.between.get("off_terrain", 0) >= 0
    a, b = dataclasses.asdict(alone), dataclasses.asdict(joined.summary)
    for d in (a, b):
        d.pop("seconds"), d.pop("seconds_by_effect")
    # the gates count work, like the seconds: each part places its lead row again
    ga, gb = a.pop("gates")["certificate"], b.pop("gates")["certificate"]
    assert 0 <= gb["checked"] - ga["checked"] <= 2 * (joined.parts - 1)
    assert a == b
    rebuilt = summary_of(ReplayTally.of_summary(alone), True, alone.seconds, alone.entities)
    assert dataclasses.replace(rebuilt, warnings=alone.warnings, time_origin=alone.time_origin) == alone
