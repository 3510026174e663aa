"""The motion between rows, as a user meets it: headings and turrets that wrap, rows at one time, a
contact across a chunk boundary, blocks of sub-steps (each effect's own cases: tests/replay/effects/)."""

import numpy as np
import pytest

from tests.replay.scenes import replay_csv, wall_scene


@pytest.mark.parametrize("yaw0,yaw1,hit", [(170, -170, True), (-170, 170, True), (10, -10, False)])
def test_the_heading_wraps_the_short_way(run, tmp_path, yaw0, yaw1, hit):
    # a thin post due west, 5.9 m out: only the gun (its muzzle 6.1 m ahead, turret forward) reaches
    # it, and only heading west: turning 170 -> -170 goes through 180 (20 deg), not round by east
    cx, cy = 60.0, 30.0
    wall_scene(tmp_path, [cx - 5.92, cy - 0.02, 95.0], [cx - 5.88, cy + 0.02, 105.0], vehicle="")
    _, events, summary = replay_csv(run, tmp_path, f"t,x,y,yaw_deg\n0,{cx},{cy},{yaw0}\n1,{cx},{cy},{yaw1}\n")
    between = [(e["a"], e["between"]) for e in events if e["kind"] == "obstacle"]
    assert between == ([("gun", True)] if hit else [])
    assert summary["motion"]["substeps"] == 19  # 20 deg of turn at 1 deg


def test_a_half_turn_goes_counter_clockwise(run, tmp_path):
    # the turret from 0 to 180 exactly: counter-clockwise, the gun over the left side, into a wall there
    wall_scene(tmp_path, [40.0, 34.0, 95.0], [80.0, 34.3, 105.0], vehicle="")
    rows = "t,x,y,yaw_deg,turret_deg,gun_deg\n0,60,30,0,0,0\n1,60,30,0,180,0\n"
    _, events, _ = replay_csv(run, tmp_path, rows)
    assert [(e["a"], e["b"], e["between"]) for e in events if e["kind"] == "obstacle"] == [("gun", "wall", True)]
    # the same half turn, started from -180 (the same angle), still turns counter-clockwise: over the right side
    _, events, _ = replay_csv(run, tmp_path, rows.replace(",0,0,0\n1", ",0,-180,0\n1").replace(",180,0\n", ",0,0\n"))
    assert [e for e in events if e["kind"] == "obstacle"] == []


def test_rows_at_the_same_time_have_no_motion_between_them(run, tmp_path):
    wall_scene(tmp_path, [50.0, 10.0, 95.0], [50.2, 50.0, 105.0])
    result, events, summary = replay_csv(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n0,60,30,0\n")
    assert events == [] and summary["motion"]["intervals"] == 0
    assert "same t" in result.stderr  # the jump itself is a warning


def test_a_contact_across_a_chunk_boundary_is_reported_once(tmp_path):
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay
    from tankcd_cli.replay.world import WorldSpec

    wall_scene(tmp_path, [50.0, 10.0, 95.0], [50.2, 50.0, 105.0])
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
