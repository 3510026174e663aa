"""Replay through scenes: effects as the scene calls for, events, summaries, pipelines, streaming."""

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"
GOLDEN = Path(__file__).resolve().parents[1] / "golden"


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    from tankcd_cli.replay.demo import run_demo

    out = tmp_path_factory.mktemp("demo")
    summary = run_demo(str(out))
    return out, summary


def test_demo_writes_everything_and_finds_every_kind(demo):
    out, summary = demo
    for name in summary["files"]:
        assert (out / name).stat().st_size > 0
    ev = summary["events"]
    assert ev["obstacle"] > 0 and ev["internal"] > 0 and ev["terrain"] > 0 and ev["off_terrain"] == 0
    assert summary["effects"] == {"terrain_contact": True, "obstacles": True, "internal": True}
    rows = (out / "poses.csv").read_text().splitlines()
    assert len(rows) == summary["rows"] + 1


def _events(path):
    return [json.loads(line) for line in Path(path).read_text().splitlines()]


def test_golden_events_of_the_sample_scene(demo):
    """Which steps collide with what is pinned; numbers within a tolerance."""
    out, _ = demo
    got = _events(out / "events.jsonl")
    golden_path = GOLDEN / "sample_events.jsonl"
    if os.environ.get("TANKCD_UPDATE_GOLDEN"):
        golden_path.write_text((out / "events.jsonl").read_text())
    want = _events(golden_path)
    assert [(e["step"], e["kind"], e["a"], e["b"]) for e in got] == [(e["step"], e["kind"], e["a"], e["b"]) for e in want]
    for g, w in zip(got, want):
        assert g["t"] == pytest.approx(w["t"])
        for key in ("depth", "turret_deg", "gun_deg"):
            if key in w:
                assert g[key] == pytest.approx(w[key], abs=2e-3)
        if "point" in w:
            assert np.allclose(g["point"], w["point"], atol=0.05)


def test_event_fields_follow_the_contract(demo):
    out, _ = demo
    for e in _events(out / "events.jsonl"):
        assert {"step", "t", "kind", "a", "b"} <= set(e)
        assert e["kind"] in ("obstacle", "internal", "terrain", "off_terrain")
        if e["kind"] == "internal":
            assert e["a"] == "gun" and e["b"].startswith("drum")
        if e["kind"] == "obstacle":
            assert e["b"] in ("wall", "depot") and len(e["point"]) == 3


def test_terrain_only_scene_loads_no_trees(run, tmp_path, monkeypatch):
    import tankcd_cli.collision.obstacles as obstacles

    def forbidden(*a, **k):
        raise AssertionError("a tree was loaded for a scene without obstacles")
    monkeypatch.setattr(obstacles, "load_obstacles", forbidden)
    monkeypatch.setattr(obstacles, "scene_vehicle_body", forbidden)
    (tmp_path / "s.toml").write_text(f'[terrain]\npath = "{SAMPLE / "battlefield.asc"}"\n[vehicle]\nfuel_drums = false\n')
    result = run("replay", SAMPLE / "patrol.csv", "--scene", "s.toml", "--poses", "p.csv", "--summary")
    assert result.exit_code == 0, result.stderr
    summary = json.loads(result.stderr.strip().splitlines()[-1])
    assert summary["effects"] == {"terrain_contact": True, "obstacles": False, "internal": False}
    assert summary["collisions"]["obstacle"] == 0 and summary["collisions"]["internal"] == 0
    assert summary["rows"] == 1144


def test_no_turret_columns_no_gun_checks(run, tmp_path):
    (tmp_path / "t.csv").write_text("t,x,y,yaw_deg\n0,500100,4500027,180\n")
    result = run("replay", "t.csv", "--scene", SAMPLE / "scene.toml", "--summary")
    assert result.exit_code == 0, result.stderr
    summary = json.loads(result.stderr.strip().splitlines()[-1])
    assert summary["effects"]["internal"] is False and summary["effects"]["obstacles"] is True


def test_fail_on_collision_and_events_file(run, tmp_path):
    result = run("replay", SAMPLE / "patrol.csv", "--scene", SAMPLE / "scene.toml", "--poses", "p.csv",
                 "--events", "e.jsonl", "--fail-on-collision")
    assert result.exit_code == 1
    assert "collisions at rows: obstacle" in result.stderr
    assert len((tmp_path / "e.jsonl").read_text().splitlines()) > 0


def test_bad_row_leaves_no_events_file(run, tmp_path):
    text = (SAMPLE / "patrol.csv").read_text() + "999,500000,nan,0,0,0\n"
    (tmp_path / "t.csv").write_text(text)
    result = run("replay", "t.csv", "--scene", SAMPLE / "scene.toml", "--poses", "p.csv", "--events", "e.jsonl")
    assert result.exit_code == 3 and "column y" in result.stderr
    assert not (tmp_path / "p.csv").exists() and not (tmp_path / "e.jsonl").exists()


def test_shell_pipeline_into_head(tmp_path):
    cmd = f"cat {SAMPLE / 'patrol.csv'} | {sys.executable} -m tankcd_cli replay - --scene {SAMPLE / 'scene.toml'} | head -3"
    proc = subprocess.run(cmd, shell=True, capture_output=True, text=True)
    assert proc.stdout.splitlines()[0].startswith("step,t,x,y,z")
    assert len(proc.stdout.splitlines()) == 3
    assert "Traceback" not in proc.stderr


def _rows(n, start=0):
    k = np.arange(start, start + n)
    x = 500010 + (k % 2000) * 0.1
    return "".join(f"{i * 0.01:.2f},{xx:.2f},4500080,0\n" for i, xx in zip(k, x))


def test_first_poses_appear_before_the_input_ends(tmp_path):
    store = tmp_path / "bf.h5"
    subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", str(SAMPLE / "battlefield.asc"), "-o", str(store)],
                   check=True)
    proc = subprocess.Popen([sys.executable, "-m", "tankcd_cli", "-q", "replay", "-", "--terrain", str(store)],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    lines = []
    two_rows = threading.Event()

    def drain():  # read all the time, so the child never blocks on a full pipe
        for line in proc.stdout:
            lines.append(line)
            if len(lines) >= 2:
                two_rows.set()
    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    proc.stdin.write("t,x,y,yaw_deg\n" + _rows(70000))  # more than one chunk, and the input stays open
    proc.stdin.flush()
    streamed = two_rows.wait(timeout=120)
    proc.stdin.close()
    proc.wait(timeout=120)
    reader.join(timeout=10)
    assert streamed and lines[1].startswith("0,")
    assert len(lines) == 70001


def _peak_rss_mb(rows, store):
    code = ("import resource, subprocess, sys\n"
            f"p = subprocess.Popen([sys.executable, '-m', 'tankcd_cli', '-q', 'replay', '-', '--terrain', {str(store)!r}],"
            " stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)\n"
            "p.stdin.write('t,x,y,yaw_deg\\n')\n"
            f"for s in range(0, {rows}, 50000):\n"
            f"    p.stdin.write(''.join(f'{{i * 0.01:.2f}},{{500010 + (i % 2000) * 0.1:.2f}},4500080,0\\n' for i in range(s, min(s + 50000, {rows}))))\n"
            "p.stdin.close(); p.wait()\n"
            "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024)")
    return float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)


def test_memory_stays_bounded_on_long_inputs(tmp_path):
    store = tmp_path / "bf.h5"
    subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", str(SAMPLE / "battlefield.asc"), "-o", str(store)],
                   check=True)
    small = _peak_rss_mb(70_000, store)
    large = _peak_rss_mb(700_000, store)
    assert large - small < 60, (small, large)  # ten times the rows, the same chunks


def test_obstacle_events_name_every_part_every_triangle_pair_puts_in_contact(demo):
    """The row events against the brute force over every triangle pair of each vehicle part and each
    obstacle, at the poses the CSV gives: one event per (row, obstacle, part) in contact, no more,
    no fewer (the sample patrol drives hull, both tracks, turret, gun and drums into the wall)."""
    from tankcd_cli.bvh.query import collide_brute_force
    from tankcd_cli.collision.obstacles import placed_triangles, scene_vehicle_body
    from tankcd_cli.collision.vehicle_body import group_of, group_placements
    from tankcd_cli.io.poses_csv import read_poses
    from tankcd_cli.scene import load_scene
    from tankcd_cli.vehicle_mesh import PARTS, vehicle_mesh

    out, _ = demo
    scene = load_scene(str(out / "scene.toml"))
    body = scene_vehicle_body(scene)
    tris, parts = vehicle_mesh(scene.vehicle, 2)
    step, _, R, position, _, _, _ = next(read_poses(str(out / "poses.csv"), 10 ** 7))
    trajectory = np.genfromtxt(out / "patrol.csv", delimiter=",", names=True)
    turret, gun = np.radians(trajectory["turret_deg"]), np.radians(trajectory["gun_deg"])
    expected = set()
    for spec in scene.obstacles:
        obstacle, _ = placed_triangles(spec)
        # rows within the vehicle's reach of the obstacle's box (no point of it is farther from its origin)
        lo, hi = obstacle.reshape(-1, 3).min(axis=0), obstacle.reshape(-1, 3).max(axis=0)
        near = np.flatnonzero(((position > lo - body.radius) & (position < hi + body.radius)).all(axis=1))
        for group in body.groups:
            Rg, tg = group_placements(body, group, R[near], position[near], turret[near], gun[near])
            for p, name in enumerate(PARTS):
                if group_of(name) == group.kind and (parts == p).any():
                    found = collide_brute_force(tris[parts == p], obstacle, Rg, tg)
                    expected |= {(int(step[near[k]]), name, spec.name) for k in np.flatnonzero(found)}
    rows = [(e["step"], e["a"], e["b"]) for e in _events(out / "events.jsonl")
            if e["kind"] == "obstacle" and not e.get("between")]
    assert len(rows) == len(set(rows)) and set(rows) == expected
    assert {"hull", "track_left", "track_right"} <= {a for _, a, _ in rows}
