"""The sampling-rate stage of the trade-off report: the motion logged at a rate, and the contacts a
check at the rows alone misses, against closed forms."""

import math

import numpy as np
import pytest

from tankcd_cli.tradeoff.measure import RATES_HZ, contacts, missed_contacts, rate_row, resample
from tankcd_cli.tradeoff.timing import spread_caveat, spread_flag
from tests.conftest import trajectory_columns, write_asc, write_obj

HALF_LENGTH = 3.43  # the box hull's half length, m


def test_resampling_a_10_hz_drive_at_lower_rates_keeps_its_rows():
    t = np.arange(101) * 0.1
    c = trajectory_columns(t, 3 * t, np.sin(t), 20 * t, 30 * t, -t)
    for hz, every in ((1.0, 10), (2.0, 5), (5.0, 2), (10.0, 1)):
        r = resample(c, hz)
        np.testing.assert_allclose(r["t"], t[::every], atol=1e-12)
        np.testing.assert_allclose(r["x"], c["x"][::every], atol=1e-9)
        np.testing.assert_allclose(r["gun_deg"], c["gun_deg"][::every], atol=1e-9)
    fine = resample(c, 50.0)
    assert len(fine["t"]) == 501
    np.testing.assert_allclose(fine["x"], 3 * fine["t"], atol=1e-9)  # a straight drive stays straight


def _ev(step, t, kind="obstacle", b="wall", between=False):
    e = {"step": step, "t": t, "kind": kind, "a": "hull", "b": b}
    if between:
        e["between"] = True
    return e


def test_contacts_are_runs_of_rows_and_contacts_beginning_between_them():
    rows_only = [_ev(3, 3.0), _ev(4, 4.0), _ev(7, 7.0), _ev(3, 3.0, "internal", "left_drum")]
    continuous = rows_only + [_ev(6, 6.5, between=True), _ev(9, 9.2, between=True),
                              _ev(4, 4.0, "obstacle", "wall")]  # a second part at row 4: the same contact
    found = contacts(continuous)
    assert [(c["kind"], c["key"][-1], c["steps"], c["between"]) for c in found] == [
        ("obstacle", "wall", [3, 4], False), ("internal", "left_drum", [3], False),
        ("obstacle", "wall", [7], True), ("obstacle", "wall", [], True)]
    missed, late = missed_contacts(continuous, rows_only)
    assert [c["t"] for c, _ in missed] == [9.2]
    assert [(c["t"], lag) for c, lag in late] == [(6.5, pytest.approx(0.5))]


def test_a_ratio_whose_range_is_too_wide_or_holds_one_is_flagged():
    assert spread_flag(1.8, 2.2) == "" and spread_caveat(1.8, 2.2) == ""
    assert "cannot tell" in spread_flag(0.9, 1.3) and "cannot tell" in spread_caveat(0.9, 1.3)
    assert "too wide" in spread_flag(2.5, 6.0) and "factor of 2.4" in spread_caveat(2.5, 6.0)
    assert spread_flag(2.0, 3.0) == ""  # a factor of exactly 1.5 still reads


@pytest.fixture(scope="module")
def wall_world(tmp_path_factory):
    """Flat ground at 100 m, a wall 0.2 m thick across x = 50 .. 50.2, and a T-72-sized box for a hull."""
    from tankcd_cli.api import load_world
    from tankcd_cli.vehicle_mesh import box

    d = tmp_path_factory.mktemp("wall")
    write_asc(d / "ground.asc", np.full((60, 120), 100.0))
    for name, lo, hi in (("wall", [50.0, 10.0, 95.0], [50.2, 50.0, 105.0]),
                         ("tank", [-HALF_LENGTH, -1.73, 0.49], [HALF_LENGTH, 1.73, 2.19])):
        tris = box(lo, hi)
        write_obj(d / f"{name}.obj", tris.reshape(-1, 3), np.arange(len(tris) * 3).reshape(-1, 3))
    (d / "scene.toml").write_text('[terrain]\npath = "ground.asc"\n\n[vehicle]\npreset = "t72"\nmesh = "tank.obj"\n\n'
                                  '[[obstacle]]\nname = "wall"\npath = "wall.obj"\nposition = [0.0, 0.0, 0.0]\n')
    return load_world(scene=str(d / "scene.toml"))


def test_a_wall_crossed_between_1_hz_rows_is_missed_by_the_rows_alone_and_only_there(wall_world):
    # 15 m/s through the wall: the box touches it while its front is past x = 50 and its rear short
    # of 50.2, x in [50 - 3.43, 50.2 + 3.43], t in [t_in, t_out]
    x0, speed = 40.0, 15.0
    drive = trajectory_columns([0.0, 4.0], [x0, x0 + 4 * speed], [30.0, 30.0], [0.0, 0.0])
    t_in, t_out = (50.0 - HALF_LENGTH - x0) / speed, (50.2 + HALF_LENGTH - x0) / speed
    assert 0 < t_in < t_out < 1  # between the 1 Hz rows at 0 and 1 s; the 2 Hz row at 0.5 s inside
    for hz in RATES_HZ:
        row_times = np.arange(int(4 * hz) + 1) / hz
        seen = row_times[(row_times >= t_in) & (row_times <= t_out)]
        r = rate_row(wall_world, drive, hz, repeats=1)
        assert r.rows == len(row_times)
        assert r.contacts["obstacle"] == 1 and sum(r.contacts.values()) == 1, (hz, r.contacts)
        assert r.missed["obstacle"] == (0 if len(seen) else 1), (hz, r.missed)
        assert sum(r.late.values()) == (1 if len(seen) else 0), (hz, r.late)
        if len(seen):  # seen at the first row inside the contact: the delay in closed form, to 1 ms
            assert r.lag_max == pytest.approx(seen[0] - t_in, abs=1e-3), hz
        assert r.ratio_lo <= r.ratio <= r.ratio_hi and all(math.isfinite(v) for v in r.continuous + r.discrete)
