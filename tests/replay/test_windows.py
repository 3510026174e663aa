"""An exercise replayed by time windows (here, and on a Dask cluster that loses a worker) writes the
local run's poses and events byte for byte: contacts straddling a window's edge and a chunk's,
one beginning exactly at an edge, entities appearing and disappearing, windows of any length."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import write_asc

GROUND = 100.0
pytestmark = pytest.mark.filterwarnings("ignore:.*would drive sideways")
T72_WIDTH = 3.46  # m: two T-72s side by side touch when their origins are this far apart


@pytest.fixture(scope="module")
def flat(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("windows")
    write_asc(tmp / "flat.asc", np.full((80, 160), GROUND))
    (tmp / "scene.toml").write_text('[terrain]\npath = "flat.asc"\n\n[vehicle]\npreset = "t72"\nfuel_drums = false\n')
    return tmp


def _write(path, rows):
    path.write_text("t,entity,x,y,yaw_deg\n" + "".join(f"{t},{e},{x},{y},{yaw}\n" for t, e, x, y, yaw in sorted(rows)))


def _edges_exercise():
    """Contacts placed against the 2 s contact windows (edges at 0, 2, 4, ...; rows every 0.5 s):

    - A stands; B slides sideways into it at 2 m/s, first touching at 3.95 s (just before the edge at
      4 s, in the interval 3.5 to 4 s), overlapping on across it until B's last row at 6 s;
    - C stands; D appears at exactly 8 s already overlapping it (a contact there from D's first
      row: it begins at the edge) and leaves at 9.5 s;
    - E drives by alone from 5 s to 12.5 s; F is there only until 6 s (its last row);
    - G and H close on each other head-on, guns first, touching at 13.8 s inside G's interval 13.5
      to 14.25 s (rows of G every 0.75 s), across the edge at 14 s.
    """
    rows = []
    for k in range(41):
        t = 0.5 * k
        rows.append((t, "A", 30.0, 20.0, 0.0))
        if t <= 6.0:
            rows.append((t, "B", 30.0, round(T72_WIDTH + 20.0 + 2 * (3.95 - t), 4), 0.0))
        rows.append((t, "C", 90.0, 20.0, 0.0))
        if 8.0 <= t <= 9.5:
            rows.append((t, "D", 90.0, 22.0, 0.0))
        if 5.0 <= t <= 12.5:
            rows.append((t, "E", round(20 + 4 * (t - 5), 4), 60.0, 0.0))
        if t <= 6.0:
            rows.append((t, "F", 130.0, round(30 + 1.5 * t, 4), 90.0))
        rows.append((t, "H", round(132.6 - 4 * t, 4), 45.0, 180.0))
    for k in range(28):
        t = 0.75 * k
        rows.append((t, "G", round(10 + 4 * t, 4), 45.0, 0.0))
    return rows


def _wander(rng, n, seconds, area=30.0):
    """n vehicles wandering close together, each its own rate, start and end: rows in time order."""
    rows = []
    for v in range(n):
        x, y = rng.uniform(20, 20 + area), rng.uniform(15, 15 + area / 2)
        heading, speed, turn = rng.uniform(-180, 180), rng.uniform(2, 6), rng.uniform(-20, 20)
        hz = rng.choice([1.0, 2.0, 3.0])
        start = rng.uniform(0, seconds / 3)
        end = rng.uniform(start + 1, seconds)
        for k in range(int((end - start) * hz) + 1):
            t = round(start + k / hz, 3)
            rows.append((t, f"w{v}", round(x, 3), round(y, 3), round(heading, 3)))
            x = float(np.clip(x + speed / hz * np.cos(np.radians(heading)), 12, 148))
            y = float(np.clip(y + speed / hz * np.sin(np.radians(heading)), 10, 70))
            heading += turn / hz
    return rows


@pytest.fixture(scope="module")
def world(flat):
    from tankcd_cli import api

    return api.load_world(scene=str(flat / "scene.toml"))


def _local(world, flat, name, chunk_rows):
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay

    out = flat / f"{name}.{chunk_rows}.local"
    if not (out / "p.csv").exists():
        out.mkdir(exist_ok=True)
        run_replay(world, str(flat / f"{name}.csv"), ReplayOutputs(str(out / "p.csv"), str(out / "e.jsonl")),
                   ReplayOptions(chunk_rows=chunk_rows))
    return out


def _windowed(world, flat, name, chunk_rows, seconds, tmp_path):
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.windows import in_process, plan_windows, run_windows

    options = ReplayOptions(chunk_rows=chunk_rows)
    plan = plan_windows(str(flat / f"{name}.csv"), options, seconds)
    summary = run_windows(str(flat / f"{name}.csv"), ReplayOutputs(str(tmp_path / "p.csv"), str(tmp_path / "e.jsonl")),
                          in_process(world, options), plan, options)
    return plan, summary


def _same_bytes(a, b):
    for name in ("p.csv", "e.jsonl"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.parametrize("chunk_rows", [7, 65536])
@pytest.mark.parametrize("seconds", [2.0, 4.0, 6.0, 14.0, 1000.0])
def test_a_windowed_run_is_the_local_run_byte_for_byte(world, flat, tmp_path, chunk_rows, seconds):
    _write(flat / "edges.csv", _edges_exercise())
    local = _local(world, flat, "edges", chunk_rows)
    plan, summary = _windowed(world, flat, "edges", chunk_rows, seconds, tmp_path)
    assert len(plan.tasks) == {2.0: 11, 4.0: 6, 6.0: 4, 14.0: 2, 1000.0: 1}[seconds]
    _same_bytes(local, tmp_path)
    events = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    pairs = sorted((e["a"], e["b"], e["t"]) for e in events if e["kind"] == "vehicle")
    # each contact once: the one just before the edge at 4 s, the one exactly at 8 s, the one across 14 s
    assert [p[:2] for p in pairs] == [("A", "B"), ("C", "D"), ("G", "H")], pairs
    assert 3.9 < pairs[0][2] < 4.0 and pairs[1][2] == 8.0 and 13.5 < pairs[2][2] < 14.0
    assert summary.vehicle_contacts == 3 and summary.entities == 8 and summary.rows == len(_edges_exercise())


@pytest.mark.parametrize("seed", [0, 1])
def test_windows_of_any_length_give_the_local_run(world, flat, tmp_path, seed):
    rows = _wander(np.random.default_rng(seed), 10, 24.0)
    _write(flat / f"wander{seed}.csv", rows)
    local = _local(world, flat, f"wander{seed}", 11)
    events = [json.loads(line) for line in (local / "e.jsonl").read_text().splitlines()]
    assert sum(e["kind"] == "vehicle" for e in events) >= 2, "the exercise should have contacts"
    for seconds in np.random.default_rng(seed).choice([2.0, 3.0, 5.0, 8.0, 10.0, 30.0], 3, replace=False):
        out = tmp_path / f"w{seconds}"
        out.mkdir()
        _windowed(world, flat, f"wander{seed}", 11, float(seconds), out)
        _same_bytes(local, out)


def test_a_window_without_rows_of_its_own_still_runs_the_motion_across_it(world, flat, tmp_path):
    # two vehicles with rows 7 s apart, meeting in the middle: windows of 2 s hold none of their rows
    rows = [(0.0, "P", 20.0, 30.0, 0.0), (7.0, "P", 90.0, 30.0, 0.0),
            (0.0, "Q", 120.0, 30.0, 180.0), (7.0, "Q", 50.0, 30.0, 180.0)]
    from tankcd_cli import api
    from tankcd_cli.replay.records import ReplayOptions
    from tankcd_cli.replay.windows import plan_windows

    _write(flat / "sparse.csv", rows)
    local = _local(world, flat, "sparse", 65536)
    plan = plan_windows(str(flat / "sparse.csv"), ReplayOptions(), 2.0)
    assert len(plan.tasks) == 4 and [len(t.lead) for t in plan.tasks] == [0, 2, 2, 2]
    assert [len(t.trailing) for t in plan.tasks] == [2, 2, 2, 0]
    summary = api.replay_windows(str(flat / "sparse.csv"), str(tmp_path / "p.csv"), str(tmp_path / "e.jsonl"),
                                 world=world, window_seconds=2.0)  # the Python API
    _same_bytes(local, tmp_path)
    assert summary.rows == 4 and summary.entities == 2 and summary.vehicle_contacts == 1
    assert any(json.loads(line)["kind"] == "vehicle" for line in (tmp_path / "e.jsonl").read_text().splitlines())


def test_the_command_line_replays_by_windows(run, world, flat, tmp_path):
    _write(flat / "edges.csv", _edges_exercise())
    local = _local(world, flat, "edges", 65536)
    result = run("replay", flat / "edges.csv", "--scene", flat / "scene.toml", "--window-seconds", "5",
                 "--poses", tmp_path / "p.csv", "--events", tmp_path / "e.jsonl", "--summary")
    assert result.exit_code == 0, result.stderr
    _same_bytes(local, tmp_path)
    summary = json.loads(result.stderr.strip().splitlines()[-1])
    assert summary["vehicle_contacts"] == 3 and summary["rows"] == len(_edges_exercise())
    for extra, message in (((flat / "edges.csv", "--out-dir", tmp_path / "o"), "fleet mode"),
                           (("-",), "not standard input"), ((flat / "edges.csv", "--png", tmp_path / "a.png"),
                                                             "--png does not apply with --window-seconds")):
        result = run("replay", *extra, "--scene", flat / "scene.toml", "--window-seconds", "5")
        assert result.exit_code == 2 and message in result.stderr, result.stderr


def test_a_dask_run_that_loses_a_worker_is_the_local_run(world, flat, tmp_path):
    pytest.importorskip("distributed")
    rows = _wander(np.random.default_rng(7), 12, 40.0) + [(t, e, x, y + 25, yaw) for t, e, x, y, yaw in
                                                          _edges_exercise()]
    _write(flat / "big.csv", rows)
    local = _local(world, flat, "big", 65536)
    from tests.conftest import busy_worker, start_dask_cluster, stop_processes

    address, workers, procs = start_dask_cluster(tmp_path)
    try:
        job = subprocess.Popen([sys.executable, "-m", "tankcd_cli", "replay", str(flat / "big.csv"), "--scene",
                                str(flat / "scene.toml"), "--window-seconds", "2", "--scheduler", address, "--poses",
                                str(tmp_path / "p.csv"), "--events", str(tmp_path / "e.jsonl"), "--summary"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        from distributed import Client

        with Client(address, timeout=60) as client:  # the kill comes when a worker holds a window
            victim = busy_worker(client, workers, job, "window", tries=6000)
            time.sleep(0.2)  # into the window's work
            os.kill(victim.pid, signal.SIGKILL)
            assert job.poll() is None, "the run ended before the kill"
        _, stderr = job.communicate(timeout=600)
        assert job.returncode == 0, stderr
    finally:
        stop_processes(procs)
    _same_bytes(local, tmp_path)
    summary = json.loads(stderr.strip().splitlines()[-1])
    assert summary["rows"] == len(rows) and summary["vehicle_contacts"] >= 3


@pytest.mark.parametrize("entities", [False, True])
def test_obstacles_drums_and_terrain_across_windows_as_the_local_run(tmp_path, entities):
    # the sample scene (a depot, a wall, the rear drums; the gun turning; a ditch): its patrol alone, and
    # as an exercise of three vehicles on it at other times and places, one leaving early; rows cut
    # into chunks of 97 and windows of 4 s
    from pathlib import Path

    from tankcd_cli import api
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay
    from tankcd_cli.replay.windows import in_process, plan_windows, run_windows

    sample = Path(__file__).resolve().parents[2] / "sample_data"
    lines = (sample / "patrol.csv").read_text().splitlines()
    lines = lines[:1] + lines[1::3]  # every third row: 3.3 Hz
    path = tmp_path / "patrol.csv"
    if entities:
        rows = []
        for line in lines[1:]:
            t, x, y, yaw, turret, gun = map(float, line.split(","))
            for v, (dt, dx, dy) in enumerate([(0, 0, 0), (3.3, 1.5, -2.0), (7.1, -2.5, 1.0)]):
                if not (v == 2 and t > 60):
                    rows.append((round(t + dt, 3), f"T{v}", round(x + dx, 3), round(y + dy, 3), yaw, turret, gun))
        path.write_text("t,entity,x,y,yaw_deg,turret_deg,gun_deg\n" + "".join(",".join(map(str, r)) + "\n"
                                                                             for r in sorted(rows)))
    else:
        path.write_text("\n".join(lines) + "\n")
    world = api.load_world(scene=str(sample / "scene.toml"))
    options = ReplayOptions(chunk_rows=97)
    (tmp_path / "local").mkdir()
    (tmp_path / "windows").mkdir()
    run_replay(world, str(path), ReplayOutputs(str(tmp_path / "local" / "p.csv"), str(tmp_path / "local" / "e.jsonl")),
               options)
    plan = plan_windows(str(path), options, 4.0)
    run_windows(str(path), ReplayOutputs(str(tmp_path / "windows" / "p.csv"), str(tmp_path / "windows" / "e.jsonl")),
                in_process(world, options), plan, options)
    _same_bytes(tmp_path / "local", tmp_path / "windows")
    kinds = {json.loads(line)["kind"] for line in (tmp_path / "local" / "e.jsonl").read_text().splitlines()}
    assert {"obstacle", "internal", "terrain"} <= kinds, kinds


def _events_by_content(path):
    """An events file's events, without their order (rows of another order: another place)."""
    return sorted(json.dumps(json.loads(line), sort_keys=True) for line in path.read_text().splitlines())


@pytest.mark.parametrize("chunk_rows", [10, 65536])
def test_a_vehicle_silent_past_the_horizon_is_checked_against_the_others(world, flat, tmp_path, chunk_rows):
    # A sends a row at 0 s and the next at 60 s, driving through B's path at 30 s: silent longer than
    # the 30 s after which it no longer holds the streaming contact windows back. The planning pass
    # finds its gap out of time order, and every task checks its windows with every segment it
    # needs: the contact is found whatever the chunks, as in one chunk holding everything.
    rows = [(0.0, "A", 80.0, 65.0, -90.0), (60.0, "A", 80.0, 5.0, -90.0)]
    rows += [(float(t), "B", 20.0 + 2 * t, 30.0, 0.0) for t in range(61)]
    rows += [(float(t), "C", 140.0, 70.0, 0.0) for t in range(61)]
    _write(flat / "silent.csv", rows)
    whole = _local(world, flat, "silent", 65536)
    local = _local(world, flat, "silent", chunk_rows)
    for seconds in (2.0, 10.0):
        out = tmp_path / f"w{seconds}"
        out.mkdir()
        _windowed(world, flat, "silent", chunk_rows, seconds, out)
        assert (out / "p.csv").read_bytes() == (local / "p.csv").read_bytes()
        assert _events_by_content(out / "e.jsonl") == _events_by_content(whole / "e.jsonl")
        found = [json.loads(line) for line in (out / "e.jsonl").read_text().splitlines()]
        assert [(e["a"], e["b"]) for e in found if e["kind"] == "vehicle"] == [("A", "B")]


@pytest.mark.parametrize("chunk_rows", [13, 65536])
@pytest.mark.parametrize("seconds", [2.0, 6.0])
def test_an_exercise_grouped_by_vehicle_by_windows_gives_its_time_ordered_twins_events(world, flat, tmp_path,
                                                                                      chunk_rows, seconds):
    # each vehicle's rows together (as per-vehicle loggers write them), across many chunks: the
    # windows find the contacts of the same rows in time order, each once
    rows = _edges_exercise() + [(t, e, x, y + 25, yaw) for t, e, x, y, yaw in _wander(np.random.default_rng(7), 8, 20.0)]
    _write(flat / "twin.csv", rows)
    (flat / "grouped.csv").write_text("t,entity,x,y,yaw_deg\n" + "".join(
        f"{t},{e},{x},{y},{yaw}\n" for t, e, x, y, yaw in sorted(rows, key=lambda r: (r[1], r[0]))))
    twin = _local(world, flat, "twin", chunk_rows)
    _, summary = _windowed(world, flat, "grouped", chunk_rows, seconds, tmp_path)

    def content(path):  # the steps are the rows' places in their file: compare the rest
        return sorted((e["t"], e["kind"], e["a"], e["b"], e.get("entity"), e.get("point"))
                      for e in map(json.loads, path.read_text().splitlines()))

    assert content(tmp_path / "e.jsonl") == content(twin / "e.jsonl")
    assert summary.vehicle_contacts == sum('"kind":"vehicle"' in line for line in (twin / "e.jsonl").open()) >= 3
    assert summary.rows == len(rows)


@pytest.mark.parametrize("chunk_rows", [9, 65536])
def test_gpx_tracks_by_windows_as_the_local_run(tmp_path, chunk_rows):
    # an input that is no CSV is read whole by every window: two GPX tracks (each an entity), one in two
    # segments (two pieces of motion), crossing each other on a flat UTM ground. The file holds A's
    # points, then B's: in chunks of 9 rows the local run has closed the windows of A's time before it
    # reads B, and their contact is not found; by windows neither (the same bytes either way)
    rasterio = pytest.importorskip("rasterio")
    pyproj = pytest.importorskip("pyproj")
    from rasterio.transform import from_origin

    from tankcd_cli import api
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay
    from tankcd_cli.replay.windows import in_process, plan_windows, run_windows

    x0, yn = 400000.0, 5001000.0
    with rasterio.open(tmp_path / "flat.tif", "w", driver="GTiff", height=200, width=300, count=1, dtype="float32",
                       crs="EPSG:32633", transform=from_origin(x0 - 0.5, yn + 0.5, 1.0, 1.0)) as dst:
        dst.write(np.full((200, 300), GROUND, np.float32), 1)
    to_geo = pyproj.Transformer.from_crs("EPSG:32633", "EPSG:4326", always_xy=True)

    def track(name, points):
        segs = []
        for seg in points:
            out = []
            for t, x, y in seg:
                lon, lat = to_geo.transform(x, y)
                out.append(f'<trkpt lat="{lat!r}" lon="{lon!r}"><time>2026-05-04T10:00:{t:02d}Z</time></trkpt>\n')
            segs.append("<trkseg>\n" + "".join(out) + "</trkseg>\n")
        return f"<trk>\n<name>{name}</name>\n" + "".join(segs) + "</trk>\n"

    a = [[(t, x0 + 90 + 4 * t, yn - 100) for t in range(0, 7)], [(t, x0 + 90 + 4 * t, yn - 100) for t in range(8, 30)]]
    b = [[(t, x0 + 150, yn - 40 - 4 * t) for t in range(2, 30)]]
    head = '<?xml version="1.0"?>\n<gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">\n'
    (tmp_path / "t.gpx").write_text(head + track("A", a) + track("B", b) + "</gpx>\n")
    world = api.load_world(terrain=str(tmp_path / "flat.tif"))
    options = ReplayOptions(chunk_rows=chunk_rows)
    for name in ("local", "windows"):
        (tmp_path / name).mkdir()
    outputs = {name: ReplayOutputs(str(tmp_path / name / "p.csv"), str(tmp_path / name / "e.jsonl"))
               for name in ("local", "windows")}
    run_replay(world, str(tmp_path / "t.gpx"), outputs["local"], options)
    plan = plan_windows(str(tmp_path / "t.gpx"), options, 4.0)
    assert len(plan.tasks) > 3 and all(task.parts is None for task in plan.tasks)
    run_windows(str(tmp_path / "t.gpx"), outputs["windows"], in_process(world, options), plan, options)
    _same_bytes(tmp_path / "local", tmp_path / "windows")
    # converted once by the planning pass (the terrain's CRS given), read by the tasks by range: the same
    plan = plan_windows(str(tmp_path / "t.gpx"), options, 4.0, crs=world.crs)
    assert plan.spool is not None and all(task.spool is not None for task in plan.tasks)
    run_windows(str(tmp_path / "t.gpx"), outputs["windows"], in_process(world, options), plan, options)
    _same_bytes(tmp_path / "local", tmp_path / "windows")
    assert plan.spool is None
    events = [json.loads(line) for line in (tmp_path / "local" / "e.jsonl").read_text().splitlines()]
    if chunk_rows == 65536:
        assert [(e["a"], e["b"]) for e in events if e["kind"] == "vehicle"] == [("A", "B")]


def _ends_in_contact(last_alone=False):
    """B slides sideways into A, their contact beginning at 6.5 s in the last 2 s window (6 to 8 s),
    which the local run closes only after its last chunk; with ``last_alone`` a third vehicle's one
    and only row is the file's last."""
    rows = []
    for k in range(15):
        t = 0.5 * k
        rows.append((t, "A", 30.0, 20.0, 0.0))
        rows.append((t, "B", 30.0, round(T72_WIDTH + 20 + 2 * (6.5 - t), 4), 0.0))
    if last_alone:
        rows.append((7.0, "Z", 120.0, 60.0, 0.0))
    return rows


@pytest.mark.parametrize("last_alone", [False, True])
@pytest.mark.parametrize("chunk_rows", [4, 65536])
def test_a_contact_in_the_last_window_and_a_last_row_at_the_end(world, flat, tmp_path, chunk_rows, last_alone):
    name = f"ends{int(last_alone)}"
    _write(flat / f"{name}.csv", _ends_in_contact(last_alone))
    local = _local(world, flat, name, chunk_rows)
    events = [json.loads(line) for line in (local / "e.jsonl").read_text().splitlines()]
    assert [(e["a"], e["b"]) for e in events if e["kind"] == "vehicle"] == [("A", "B")]
    for seconds in (2.0, 3.0, 6.0, 100.0):
        out = tmp_path / f"w{seconds}"
        out.mkdir()
        plan, summary = _windowed(world, flat, name, chunk_rows, seconds, out)
        _same_bytes(local, out)
        assert summary.vehicle_contacts == 1 and summary.rows == len(_ends_in_contact(last_alone))
    # the map of the run in one piece marks the contact found after the last chunk
    from tankcd_cli.replay.drawing import ReplayDrawing
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay

    drawing = ReplayDrawing()
    run_replay(world, str(flat / f"{name}.csv"), ReplayOutputs(None, None), ReplayOptions(chunk_rows=chunk_rows),
               observe=drawing.observe)
    assert drawing.counts.get("vehicle") == 1 and [m[0] for m in drawing.marks] == ["vehicle"]


def test_the_command_line_draws_an_exercise_ending_in_a_contact(run, flat, tmp_path):
    _write(flat / "ends0.csv", _ends_in_contact())
    result = run("replay", flat / "ends0.csv", "--scene", flat / "scene.toml", "--poses", tmp_path / "p.csv",
                 "--png", tmp_path / "map.png")
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "map.png").stat().st_size > 0


def test_a_windowed_summary_counts_what_the_run_in_one_piece_counts(world, flat, tmp_path):
    # the vehicles' checks take time (seconds_by_effect "vehicles"), as in one piece; every field but
    # the seconds is the one-piece summary's, the warnings of the planning pass included
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay

    _write(flat / "edges.csv", _edges_exercise())
    whole = run_replay(world, str(flat / "edges.csv"), ReplayOutputs(None, None), ReplayOptions())
    _, windowed = _windowed(world, flat, "edges", 65536, 2.0, tmp_path)
    assert set(windowed.seconds_by_effect) == set(whole.seconds_by_effect) >= {"vehicles", "matching", "between"}
    assert windowed.seconds_by_effect["vehicles"] > 0
    a, b = whole.as_dict(), windowed.as_dict()
    for d in (a, b):
        d.pop("seconds"), d.pop("seconds_by_effect")
    # the gates count work, like the seconds: a window places the rows it starts from again
    ga, gb = a.pop("gates")["certificate"], b.pop("gates")["certificate"]
    assert ga["checked"] <= gb["checked"] and ga["skipped"] <= gb["skipped"]
    assert a == b
    assert any("drive sideways" in w for w in windowed.warnings)


def test_the_tasks_warnings_are_said_once_and_kept_in_the_summary(run, flat, tmp_path, monkeypatch):
    # every task raises the same warning and one of its own: the command says each once, and the
    # summary lists each once, after the planning pass's
    from tankcd_cli.errors import warn
    from tankcd_cli.replay import windows

    real = windows._read_window

    def warning_read(world, task):
        warn("exercise", "a warning every window raises")
        warn("exercise", f"the warning of window {task.index}")
        return real(world, task)

    monkeypatch.setattr(windows, "_read_window", warning_read)
    _write(flat / "edges.csv", _edges_exercise())
    result = run("replay", flat / "edges.csv", "--scene", flat / "scene.toml", "--window-seconds", "4",
                 "--poses", tmp_path / "p.csv", "--summary")
    assert result.exit_code == 0, result.stderr
    said = [line for line in result.stderr.splitlines() if line.startswith("tankcd: warning:")]
    assert said.count("tankcd: warning: exercise: a warning every window raises") == 1
    assert len(said) == len(set(said))
    summary = json.loads(result.stderr.strip().splitlines()[-1])
    listed = summary["warnings"]
    assert len(listed) == len(set(listed)) == len(said)
    assert listed.index("exercise: a warning every window raises") < listed.index("exercise: the warning of window 1")
    assert [w for w in listed if "window 5" in w] == ["exercise: the warning of window 5"]
    assert any("drive sideways" in w for w in listed[:2])
    # --strict: a warning is bad input, and nothing is written
    result = run("replay", flat / "edges.csv", "--scene", flat / "scene.toml", "--window-seconds", "4",
                 "--poses", tmp_path / "q.csv", "--strict")
    assert result.exit_code == 3 and not (tmp_path / "q.csv").exists()


def _parquet(path):
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    meta = {k.decode(): v.decode() for k, v in (table.schema.metadata or {}).items()}
    return table.to_pylist(), meta


@pytest.mark.parametrize("chunk_rows,seconds", [(7, 2.0), (65536, 6.0), (65536, 1000.0)])
def test_windows_write_the_parquet_of_the_run_in_one_piece(world, flat, tmp_path, chunk_rows, seconds):
    # the same writers: the same tables (rows, columns, types, entity names) and the same metadata
    pytest.importorskip("pyarrow")
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay
    from tankcd_cli.replay.windows import in_process, plan_windows, run_windows

    _write(flat / "edges.csv", _edges_exercise())
    path = str(flat / "edges.csv")
    options = ReplayOptions(chunk_rows=chunk_rows)
    whole = tmp_path / "whole"
    whole.mkdir()
    run_replay(world, path, ReplayOutputs(str(whole / "p.parquet"), str(whole / "e.parquet")), options)
    mixed = (("p.parquet", "e.jsonl"), ("p.csv", "e.parquet")) if seconds == 6.0 else ()
    for poses, events in (("p.parquet", "e.parquet"),) + mixed:
        out = tmp_path / f"w-{poses}-{events}"
        out.mkdir()
        plan = plan_windows(path, options, seconds)
        summary = run_windows(path, ReplayOutputs(str(out / poses), str(out / events)), in_process(world, options),
                              plan, options)
        assert summary.vehicle_contacts == 3
        for name in (poses, events):
            if name.endswith(".parquet"):
                got, want = _parquet(out / name), _parquet(whole / name)
                assert got[0] == want[0], name
                assert got[1] == want[1], name
    if mixed:  # the text outputs beside them: the local run's bytes
        local = _local(world, flat, "edges", chunk_rows)
        assert (tmp_path / "w-p.parquet-e.jsonl" / "e.jsonl").read_bytes() == (local / "e.jsonl").read_bytes()
        assert (tmp_path / "w-p.csv-e.parquet" / "p.csv").read_bytes() == (local / "p.csv").read_bytes()
    rows, meta = _parquet(whole / "p.parquet")
    assert len(rows) == len(_edges_exercise()) and {r["entity"] for r in rows} == set("ABCDEFGH")
    assert meta["tankcd.table"] == "poses" and "sha256" in meta["tankcd.sources"]


def test_the_command_line_writes_parquet_by_windows(run, flat, tmp_path):
    pytest.importorskip("pyarrow")
    _write(flat / "edges.csv", _edges_exercise())
    for name, extra in (("w", ("--window-seconds", "4")), ("whole", ())):
        result = run("replay", flat / "edges.csv", "--scene", flat / "scene.toml", *extra,
                     "--poses", tmp_path / f"{name}.p.parquet", "--events", tmp_path / f"{name}.e.parquet")
        assert result.exit_code == 0, result.stderr
    for table in ("p", "e"):
        assert _parquet(tmp_path / f"w.{table}.parquet") == _parquet(tmp_path / f"whole.{table}.parquet")


@pytest.mark.parametrize("suffixes", [(".csv", ".jsonl"), (".parquet", ".parquet")])
def test_windows_in_two_processes_write_the_bytes_of_one(run, flat, tmp_path, suffixes):
    # the windows on a forked pool (--jobs 2) as here one after the other: byte for byte, CSV and Parquet,
    # and the summary's counts the same
    if suffixes[0] == ".parquet":
        pytest.importorskip("pyarrow")
    _write(flat / "edges.csv", _edges_exercise())
    summaries = {}
    for jobs in ("1", "2"):
        out = tmp_path / f"jobs{jobs}"
        out.mkdir()
        result = run("replay", flat / "edges.csv", "--scene", flat / "scene.toml", "--window-seconds", "2",
                     "--jobs", jobs, "--poses", out / f"p{suffixes[0]}", "--events", out / f"e{suffixes[1]}",
                     "--summary", out / "s.json")
        assert result.exit_code == 0, result.stderr
        summaries[jobs] = json.loads((out / "s.json").read_text())
    for name in (f"p{suffixes[0]}", f"e{suffixes[1]}"):
        assert (tmp_path / "jobs1" / name).read_bytes() == (tmp_path / "jobs2" / name).read_bytes()
    for key in ("rows", "collisions", "between", "vehicle_contacts", "matchers", "entities"):
        assert summaries["1"][key] == summaries["2"][key]


def test_a_worker_describes_the_world_as_the_local_run(world, flat):
    # on a cluster the world is loaded by the workers only: one of them gives the Parquet metadata
    from tankcd_cli.replay.executor import TaskWorld
    from tankcd_cli.replay.records import ReplayOptions
    from tankcd_cli.replay.windows import in_process, window_metadata
    from tankcd_cli.replay.world import WorldSpec

    _write(flat / "edges.csv", _edges_exercise())
    options = ReplayOptions()
    remote = window_metadata(TaskWorld(WorldSpec(scene=str(flat / "scene.toml")), options), str(flat / "edges.csv"))
    assert remote == in_process(world, options).metadata(str(flat / "edges.csv"))


def _utm_ground(tmp_path):
    rasterio = pytest.importorskip("rasterio")
    pytest.importorskip("pyproj")
    from rasterio.transform import from_origin

    x0, yn = 400000.0, 5001000.0
    with rasterio.open(tmp_path / "flat.tif", "w", driver="GTiff", height=200, width=300, count=1, dtype="float32",
                       crs="EPSG:32633", transform=from_origin(x0 - 0.5, yn + 0.5, 1.0, 1.0)) as dst:
        dst.write(np.full((200, 300), GROUND, np.float32), 1)
    return x0, yn


def _capture_exercise(path, x0, yn):
    """A DIS capture (pcap) of three tanks on UTM 33N ground: A stands, B drives west into it (their
    hulls meet about 11.4 s in), C crosses far from both from 6 s; 2 Hz each, B's packets a little
    after A's, and the file's last packets hold the contact's end."""
    import pyproj

    from tankcd_cli.io.geodesy import enu_basis
    from tests.io import captures as C
    from tests.io.test_dis import T0, ecef

    to_geo = pyproj.Transformer.from_crs("EPSG:32633", "EPSG:4326", always_xy=True)

    def pdu(ent, x, y, yaw_deg):
        lon, lat = to_geo.transform(x, y)
        yaw = np.radians(yaw_deg)
        enu = np.array([[np.cos(yaw), np.sin(yaw), 0], [np.sin(yaw), -np.cos(yaw), 0], [0, 0, -1]]).T
        body = enu_basis([lon], [lat])[0].T @ enu
        ori = (np.arctan2(body[1, 0], body[0, 0]), -np.arcsin(body[2, 0]), np.arctan2(body[2, 1], body[2, 2]))
        return C.ethernet(C.ipv4(C.udp(C.es_dis7(1, 1, ent, ecef(lon, lat, 100.0), ori))))

    frames = []
    for k in range(31):
        t = 0.5 * k
        frames.append((T0 + t, pdu(1, x0 + 100, yn - 100, 0.0)))
        frames.append((T0 + t + 0.1, pdu(2, x0 + 160 - 4 * t, yn - 100, 180.0)))
        if t >= 6:
            frames.append((T0 + t + 0.2, pdu(3, x0 + 30 + 3 * (t - 6), yn - 20, 0.0)))
    path.write_bytes(C.pcap(frames))
    return path


@pytest.mark.parametrize("chunk_rows", [10, 65536])
def test_a_capture_by_windows_is_decoded_once_and_gives_the_run_in_one_piece(tmp_path, monkeypatch, chunk_rows):
    from tankcd_cli import api
    from tankcd_cli.io import dis
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay

    x0, yn = _utm_ground(tmp_path)
    path = str(_capture_exercise(tmp_path / "ex.pcap", x0, yn))
    world = api.load_world(terrain=str(tmp_path / "flat.tif"))
    options = ReplayOptions(chunk_rows=chunk_rows)
    for name in ("whole", "w"):
        (tmp_path / name).mkdir()
    whole = run_replay(world, path, ReplayOutputs(str(tmp_path / "whole" / "p.csv"), str(tmp_path / "whole" / "e.jsonl")),
                       options)
    assert whole.vehicle_contacts == 1 and whole.entities == 3
    decoded = []
    real = dis.DisCapture.blocks

    def counted(self, *args, **kwargs):
        decoded.append(self.path if hasattr(self, "path") else None)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(dis.DisCapture, "blocks", counted)
    spools = tmp_path / "spools"
    spools.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(spools))
    for seconds in (2.0, 5.0):
        decoded.clear()
        summary = api.replay_windows(path, str(tmp_path / "w" / "p.csv"), str(tmp_path / "w" / "e.jsonl"), world=world,
                                     window_seconds=seconds) if chunk_rows == 65536 else None
        if summary is None:  # another chunk size: the runner's own parts
            from tankcd_cli.replay.windows import in_process, plan_windows, run_windows

            plan = plan_windows(path, options, seconds, crs=world.crs)
            assert plan.spool is not None and all(t.parts is None and t.spool for t in plan.tasks)
            summary = run_windows(path, ReplayOutputs(str(tmp_path / "w" / "p.csv"), str(tmp_path / "w" / "e.jsonl")),
                                  in_process(world, options), plan, options)
        assert len(decoded) == 1, decoded  # the planning pass alone: no task decodes the capture again
        _same_bytes(tmp_path / "whole", tmp_path / "w")
        assert summary.vehicle_contacts == 1 and summary.rows == whole.rows
        assert summary.warnings == whole.warnings
        assert not list(spools.iterdir())  # the converted rows removed once the windows have run


def test_minus_v_shows_the_traceback_of_a_tasks_internal_error(run, flat, tmp_path, monkeypatch):
    from tankcd_cli.replay import windows

    def broken(world, task):
        raise ZeroDivisionError(f"in window {task.index}")

    monkeypatch.setattr(windows, "_read_window", broken)
    _write(flat / "edges.csv", _edges_exercise())
    for verbose in ((), ("-v",)):
        result = run(*verbose, "replay", flat / "edges.csv", "--scene", flat / "scene.toml", "--window-seconds", "4",
                     "--poses", tmp_path / "p.csv")
        assert result.exit_code == 4
        assert "internal error: ZeroDivisionError: in window 0" in result.stderr
        assert ("in broken" in result.stderr) == bool(verbose), result.stderr
        assert not (tmp_path / "p.csv").exists()


def test_a_clock_jump_of_a_billion_seconds_is_replayed_in_one_piece(tmp_path):
    # windows over 1e9 s of empty time would cost by time (5e8 windows for 41 rows): the plan declines
    # and the exercise runs in one piece, which skips empty time, with the same bytes and a warning
    from tankcd_cli import api
    from tankcd_cli.errors import SetupWarning

    rows = "".join(f"{k * 0.5},A,{500040 + k},4500050,0\n{k * 0.5},B,{500080 - k},4500050,180\n" for k in range(20))
    (tmp_path / "gap.csv").write_text("t,entity,x,y,yaw_deg\n" + rows + "1000000000,A,500070,4500050,0\n")
    terrain = str(Path(__file__).resolve().parents[2] / "sample_data" / "battlefield.asc")
    whole = api.replay_to_files(str(tmp_path / "gap.csv"), str(tmp_path / "p.csv"), str(tmp_path / "e.jsonl"),
                                terrain=terrain)
    with pytest.warns(SetupWarning, match="far more windows than rows .* replayed in one piece"):
        windowed = api.replay_windows(str(tmp_path / "gap.csv"), str(tmp_path / "pw.csv"), str(tmp_path / "ew.jsonl"),
                                      terrain=terrain, window_seconds=60.0)
    assert (tmp_path / "pw.csv").read_bytes() == (tmp_path / "p.csv").read_bytes()
    assert (tmp_path / "ew.jsonl").read_bytes() == (tmp_path / "e.jsonl").read_bytes()
    assert windowed.vehicle_contacts == whole.vehicle_contacts == 1
    assert any("far more windows than rows" in w for w in windowed.warnings)
