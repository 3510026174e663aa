"""The gun against the drums along the motion: the turret's swing between two rows clear of them."""

import pytest

from tests.replay.scenes import flat, replay_csv, scene


def test_the_turret_swinging_over_the_drums_between_rows(run, tmp_path):
    flat(tmp_path)
    scene(tmp_path)
    rows = "t,x,y,yaw_deg,turret_deg,gun_deg\n0,60,30,0,150,-6\n1,60,30,0,-150,-6\n"
    result, events, summary = replay_csv(run, tmp_path, rows)
    assert result.exit_code == 0, result.stderr
    assert [(e["step"], e["kind"], e["b"], e["between"]) for e in events] == [(0, "internal", "drum_left", True)]
    assert events[0]["turret_deg"] == pytest.approx(161.68, abs=0.01)
    assert events[0]["t"] == pytest.approx((161.68 - 150) / 60, abs=0.01 / 60)
    assert summary["collisions"]["internal"] == 0  # neither row touches a drum
