"""Contacts that begin between rows, as a user meets them: tunnelling, pivots, the turret's swing, a mound."""

import json

import numpy as np
import pytest

from tests.conftest import write_asc, write_obj

GROUND = 100.0


def _flat(tmp_path, cols=120, rows=60, x0=0.0, y0=0.0, bump=None):
    z = np.full((rows, cols), GROUND)
    if bump is not None:
        bump(z, x0, y0)
    return write_asc(tmp_path / "ground.asc", z, 1.0, x0, y0)


def _box_obj(path, lo, hi):
    from tankcd_cli.vehicle_mesh import box

    tris = box(lo, hi)
    write_obj(path, tris.reshape(-1, 3), np.arange(len(tris) * 3).reshape(-1, 3))
    return path


def _scene(tmp_path, obstacles=(), vehicle="", terrain="ground.asc"):
    text = f'[terrain]\npath = "{terrain}"\n\n[vehicle]\npreset = "t72"\n{vehicle}\n'
    for name, lo, hi in obstacles:
        _box_obj(tmp_path / f"{name}.obj", lo, hi)
        text += f'\n[[obstacle]]\nname = "{name}"\npath = "{name}.obj"\nposition = [0.0, 0.0, 0.0]\n'
    (tmp_path / "scene.toml").write_text(text)
    return tmp_path / "scene.toml"


def _replay(run, tmp_path, rows, *extra):
    (tmp_path / "t.csv").write_text(rows)
    result = run("replay", "t.csv", "--scene", "scene.toml", "--poses", "p.csv", "--events", "e.jsonl", "--summary",
                 *extra)
    events = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    summary = json.loads(result.stderr.strip().splitlines()[-1])
    return result, events, summary


def _hull_mesh(tmp_path):
    # a T-72-sized box: hull length and width, from ground clearance to the turret roof
    _box_obj(tmp_path / "tank.obj", [-3.43, -1.73, 0.49], [3.43, 1.73, 2.19])
    return 'mesh = "tank.obj"\n'


def test_a_hull_at_15_m_s_drives_through_a_wall_between_rows_and_fails_the_run(run, tmp_path):
    _flat(tmp_path)
    _scene(tmp_path, [("wall", [50.0, 10.0, 95.0], [50.2, 50.0, 105.0])], _hull_mesh(tmp_path))
    rows = "t,x,y,yaw_deg\n0,40,30,0\n1,55,30,0\n"
    result, events, summary = _replay(run, tmp_path, rows, "--fail-on-collision")
    assert result.exit_code == 1
    assert [(e["step"], e["kind"], e["b"], e.get("between")) for e in events] == [(0, "obstacle", "wall", True)]
    assert events[0]["t"] == pytest.approx((50.0 - 3.43 - 40.0) / 15.0, abs=1e-3)  # 1 ms
    assert summary["collisions"]["obstacle"] == 0 and summary["between"]["obstacle"] == 1
    # the rows-only check of the paper sees nothing
    result, events, summary = _replay(run, tmp_path, rows, "--fail-on-collision", "--discrete")
    assert result.exit_code == 0 and events == [] and summary["mode"] == "discrete"


def test_a_pivot_in_place_sweeps_the_hull_into_a_post(run, tmp_path):
    _flat(tmp_path)
    cx, cy = 60.0, 30.0
    post = cx + 3.6 * np.cos(np.radians(60)), cy + 3.6 * np.sin(np.radians(60))
    _scene(tmp_path, [("post", [post[0] - 0.1, post[1] - 0.1, 95.0], [post[0] + 0.1, post[1] + 0.1, 105.0])],
           _hull_mesh(tmp_path))
    result, events, _ = _replay(run, tmp_path, f"t,x,y,yaw_deg\n0,{cx},{cy},0\n2,{cx},{cy},100\n")
    assert result.exit_code == 0, result.stderr
    # two contacts: the post enters by the left side, leaves by the front face (3.43 m out, short of
    # its 3.6 m) at about 52 deg, and meets the front face again on the far side at about 69 deg
    assert [(e["kind"], e["b"], e["between"]) for e in events] == [("obstacle", "post", True)] * 2
    assert 2 * 52 / 100 < events[1]["t"] < 2 * 70 / 100
    corners = np.array(post) - [cx, cy] + 0.1 * np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]])
    rho, beta = np.hypot(*corners.T), np.arctan2(corners[:, 1], corners[:, 0])
    angle = np.degrees(np.min(beta - np.arcsin(1.73 / rho)))  # the hull's left side meets a post corner
    assert events[0]["t"] == pytest.approx(2 * angle / 100, abs=1e-3)


def test_the_turret_swinging_over_the_drums_between_rows(run, tmp_path):
    _flat(tmp_path)
    _scene(tmp_path)
    rows = "t,x,y,yaw_deg,turret_deg,gun_deg\n0,60,30,0,150,-6\n1,60,30,0,-150,-6\n"
    result, events, summary = _replay(run, tmp_path, rows)
    assert result.exit_code == 0, result.stderr
    assert [(e["step"], e["kind"], e["b"], e["between"]) for e in events] == [(0, "internal", "drum_left", True)]
    assert events[0]["turret_deg"] == pytest.approx(161.68, abs=0.01)
    assert events[0]["t"] == pytest.approx((161.68 - 150) / 60, abs=0.01 / 60)
    assert summary["collisions"]["internal"] == 0  # neither row touches a drum


def test_the_hull_bottom_scrapes_over_a_mound_between_the_tracks(run, tmp_path):
    def mound(z, x0, y0):  # 0.8 m high, 2 m long, 1 m wide: between the tracks (inner edges 1.1 m out)
        rows, cols = z.shape
        for r in range(rows):
            for c in range(cols):
                x, y = x0 + c, y0 + (rows - 1 - r)
                if 49 <= x <= 51 and abs(y - 30) <= 0.5:
                    z[r, c] = GROUND + 0.8

    _flat(tmp_path, bump=mound)
    _scene(tmp_path)
    result, events, summary = _replay(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n1,60,30,0\n")
    assert result.exit_code == 0, result.stderr
    terrain = [e for e in events if e["kind"] == "terrain"]
    assert len(terrain) == 1 and terrain[0]["between"] and terrain[0]["step"] == 0
    assert 0.01 < terrain[0]["depth"] <= 0.8 - 0.49 + 1e-6  # at onset, on the mound's flank at the most
    # the hull's front edge reaches the mound's first posts after about (49 - 3.43 - 40) / 20 of the second
    assert (49 - 3.43 - 1 - 40) / 20 <= terrain[0]["t"] <= (51 + 3.43 - 40) / 20
    assert summary["motion"]["substep_travel_m"] == 0.5 and summary["motion"]["substeps"] == 39


# --- hard cases ---------------------------------------------------------------------------------

def _wall_scene(tmp_path, lo, hi, vehicle=None):
    _flat(tmp_path)
    return _scene(tmp_path, [("wall", lo, hi)], vehicle if vehicle is not None else _hull_mesh(tmp_path))


@pytest.mark.parametrize("yaw0,yaw1,hit", [(170, -170, True), (-170, 170, True), (10, -10, False)])
def test_the_heading_wraps_the_short_way(run, tmp_path, yaw0, yaw1, hit):
    # a thin post due west, 5.9 m out: only the gun (its muzzle 6.1 m ahead, turret forward) reaches
    # it, and only heading west: turning 170 -> -170 goes through 180 (20 deg), not round by east
    cx, cy = 60.0, 30.0
    _wall_scene(tmp_path, [cx - 5.92, cy - 0.02, 95.0], [cx - 5.88, cy + 0.02, 105.0], vehicle="")
    _, events, summary = _replay(run, tmp_path, f"t,x,y,yaw_deg\n0,{cx},{cy},{yaw0}\n1,{cx},{cy},{yaw1}\n")
    between = [(e["a"], e["between"]) for e in events if e["kind"] == "obstacle"]
    assert between == ([("gun", True)] if hit else [])
    assert summary["motion"]["substeps"] == 19  # 20 deg of turn at 1 deg


def test_a_half_turn_goes_counter_clockwise(run, tmp_path):
    # the turret from 0 to 180 exactly: counter-clockwise, the gun over the left side, into a wall there
    _wall_scene(tmp_path, [40.0, 34.0, 95.0], [80.0, 34.3, 105.0], vehicle="")
    rows = "t,x,y,yaw_deg,turret_deg,gun_deg\n0,60,30,0,0,0\n1,60,30,0,180,0\n"
    _, events, _ = _replay(run, tmp_path, rows)
    assert [(e["a"], e["b"], e["between"]) for e in events if e["kind"] == "obstacle"] == [("gun", "wall", True)]
    # the same half turn, started from -180 (the same angle), still turns counter-clockwise: over the right side
    _, events, _ = _replay(run, tmp_path, rows.replace(",0,0,0\n1", ",0,-180,0\n1").replace(",180,0\n", ",0,0\n"))
    assert [e for e in events if e["kind"] == "obstacle"] == []


def test_rows_at_the_same_time_have_no_motion_between_them(run, tmp_path):
    _wall_scene(tmp_path, [50.0, 10.0, 95.0], [50.2, 50.0, 105.0])
    result, events, summary = _replay(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n0,60,30,0\n")
    assert events == [] and summary["motion"]["intervals"] == 0
    assert "same t" in result.stderr  # the jump itself is a warning


@pytest.mark.parametrize("gap,hit", [(0.0015, False), (0.0005, None), (-0.001, True)])
def test_a_near_miss_beside_a_wall(run, tmp_path, gap, hit):
    # the hull's left side (y = 30 + 1.73) drives along a wall whose face is gap beyond it
    face = 30.0 + 1.73 + gap
    _wall_scene(tmp_path, [30.0, face, 95.0], [90.0, face + 0.3, 105.0])
    _, events, _ = _replay(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n1,41,30,0\n", "--discrete")
    at_rows = [e for e in events if e["kind"] == "obstacle"]
    _, events, _ = _replay(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n1,41,30,0\n")
    obstacle = [e for e in events if e["kind"] == "obstacle"]
    if hit is False:
        assert obstacle == []  # 1.5 mm clear all along: no event
    elif hit is True:
        # touching at both rows: reported at the rows, not again between them
        assert at_rows and obstacle == at_rows and not any(e.get("between") for e in obstacle)
    # 0.5 mm: either answer is right (a pass within 1 mm may count)


def test_a_contact_across_a_chunk_boundary_is_reported_once(tmp_path):
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay
    from tankcd_cli.replay.world import WorldSpec

    _wall_scene(tmp_path, [50.0, 10.0, 95.0], [50.2, 50.0, 105.0])
    (tmp_path / "t.csv").write_text("t,x,y,yaw_deg\n" + "".join(f"{k},{30 + 15 * k},30,0\n" for k in range(4)))
    world = WorldSpec(scene=str(tmp_path / "scene.toml")).load()

    def events_with(chunk_rows):
        seen = []
        run_replay(world, str(tmp_path / "t.csv"), ReplayOutputs(None, None), ReplayOptions(chunk_rows=chunk_rows),
                   observe=lambda chunk, poses, evs: seen.extend(evs))
        return [(e.step, e.kind, e.b, round(e.t, 6), e.between) for e in seen]

    whole = events_with(100)
    # rows at x = 30, 45, 60, 75: the hull's front (3.43 m ahead) first reaches the wall between rows 1 and 2
    assert [(s, k, b, between) for s, k, b, _, between in whole] == [(1, "obstacle", "wall", True)]
    assert events_with(1) == events_with(2) == whole  # the interval 0 -> 1 straddles chunks of one row


def test_a_path_leaving_the_terrain_between_rows(run, tmp_path):
    def hole(z, x0, y0):
        z[20:40, 55:65] = -9999.0

    _flat(tmp_path, bump=hole)
    (tmp_path / "ground.asc").write_text((tmp_path / "ground.asc").read_text().replace(
        "cellsize 1.0\n", "cellsize 1.0\nNODATA_value -9999\n"))
    _scene(tmp_path)
    _, events, summary = _replay(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n2,80,30,0\n")
    off = [e for e in events if e["kind"] == "off_terrain"]
    assert len(off) == 1 and off[0]["between"] and off[0]["step"] == 0
    assert 0 < off[0]["t"] < 2 and summary["between"]["off_terrain"] == 1


def test_blocks_of_sub_steps_change_nothing(monkeypatch):
    """The sub-steps are placed and checked in blocks of whole intervals (memory by the block): any
    block size gives the same poses, events and counts, here on the sample scene's patrol logged
    at 0.5 Hz (every effect, rows 10 m apart: tens of sub-steps an interval) and, as an exercise,
    beside a second tank parked across its path (segments for the checks between vehicles)."""
    from pathlib import Path

    from tankcd_cli import api
    from tankcd_cli.replay import between_rows

    sample = Path(__file__).resolve().parents[2] / "sample_data"
    rows = np.genfromtxt(sample / "patrol.csv", delimiter=",", names=True)
    sparse = rows[::20]
    lone = {k: sparse[k] for k in sparse.dtype.names}
    first = sparse[len(sparse) // 3]
    parked = {k: np.r_[lone[k], np.full(2, first[k])] for k in lone}
    parked["t"] = np.r_[lone["t"], lone["t"][0], lone["t"][-1]]
    order = np.argsort(parked["t"], kind="stable")
    exercise = {k: v[order] for k, v in parked.items()}
    exercise["entity"] = np.r_[np.full(len(sparse), "patrol", dtype=object), ["parked"] * 2][order]
    world = api.load_world(scene=str(sample / "scene.toml"))
    for trajectory in (lone, exercise):
        whole = api.replay(trajectory, world=world)
        monkeypatch.setattr(between_rows, "SUBSTEP_BLOCK", 5)
        blocks = api.replay(trajectory, world=world)
        monkeypatch.undo()
        assert whole[1] == blocks[1] and any(e.get("between") for e in whole[1])
        assert whole[0].keys() == blocks[0].keys()
        for k in whole[0]:
            np.testing.assert_array_equal(whole[0][k], blocks[0][k])
