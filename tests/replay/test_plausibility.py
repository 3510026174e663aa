"""Warnings about a trajectory's motion: steps no vehicle makes, big turns, headings that contradict it."""

from pathlib import Path

import pytest

from tests.conftest import write_asc

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


@pytest.fixture
def ground(tmp_path):
    import numpy as np

    return write_asc(tmp_path / "flat.asc", np.full((80, 80), 10.0))


def _warned(run, tmp_path, ground, rows):
    (tmp_path / "t.csv").write_text("t,x,y,yaw_deg\n" + "".join(",".join(map(str, r)) + "\n" for r in rows))
    loose = run("replay", "t.csv", "--terrain", ground, "--poses", "p.csv")
    assert loose.exit_code == 0, loose.stderr
    warnings = [line for line in loose.stderr.splitlines() if line.startswith("tankcd: warning:")]
    strict = run("--strict", "replay", "t.csv", "--terrain", ground, "--poses", "q.csv")
    assert strict.exit_code == (3 if warnings else 0), strict.stderr
    assert not (tmp_path / "q.csv").exists() or not warnings  # nothing written under --strict
    return warnings


def test_a_step_faster_than_any_vehicle_names_its_line(run, tmp_path, ground):
    warnings = _warned(run, tmp_path, ground, [(0, 10, 10, 0), (1, 20, 10, 0), (2, 70, 10, 0)])
    assert len(warnings) == 1 and "line 4: 50.0 m/s from line 3" in warnings[0]


def test_interleaved_vehicles_without_an_entity_column_are_named_as_such(run, tmp_path, ground):
    warnings = _warned(run, tmp_path, ground, [(0, 10, 10, 0), (0, 60, 60, 0), (1, 11, 10, 0), (1, 61, 60, 0)])
    assert any("same t" in w and "entity column" in w for w in warnings)


def test_a_turn_of_150_deg_or_more_between_two_rows(run, tmp_path, ground):
    warnings = _warned(run, tmp_path, ground, [(0, 40, 40, 0), (1, 40, 40, 150)])
    assert len(warnings) == 1 and "line 3: the heading turns 150.0 deg from line 2" in warnings[0]
    assert _warned(run, tmp_path, ground, [(0, 40, 40, 0), (1, 40, 40, 149.9)]) == []


@pytest.mark.parametrize("heading,cause", [
    (lambda travel: 90 - travel, "compass bearing"),
    (lambda travel: travel * 3.141592653589793 / 180, "radians"),
    (lambda travel: -travel, "sign"),
])
def test_headings_that_contradict_the_motion_name_the_likely_cause(run, tmp_path, ground, heading, cause):
    import math

    rows, x, y = [], 70.0, 5.0
    for k in range(20):  # a gentle curve from west-north-west to north-west, 5 m/s
        travel = 100.0 + 2.0 * k
        rows.append((k, round(x, 3), round(y, 3), round(heading(travel), 4)))
        x += 5 * math.cos(math.radians(travel))
        y += 5 * math.sin(math.radians(travel))
    warnings = _warned(run, tmp_path, ground, rows)
    assert len(warnings) == 1 and "moving rows head more than 60 deg away" in warnings[0] and cause in warnings[0]


def test_a_good_track_and_the_sample_patrol_are_quiet(run, tmp_path, ground):
    assert _warned(run, tmp_path, ground, [(k, 10 + 4 * k, 10 + 3 * k, 36.87) for k in range(10)]) == []
    result = run("replay", SAMPLE / "patrol.csv", "--scene", SAMPLE / "scene.toml", "--poses", "p.csv")
    assert result.exit_code == 0 and "warning" not in result.stderr


def _said(check, feed):
    """The warnings ``feed(check)`` raises, then those of ``check.finish()``."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        feed(check)
        check.finish()
    return [str(w.message) for w in caught]


@pytest.mark.parametrize("seed", range(6))
def test_many_vehicles_interleaved_and_chunked_are_each_vehicle_alone(seed):
    """The checks of an exercise, its rows interleaved and cut into chunks anywhere, say of each vehicle
    what they say of its rows alone, whole: the same warnings and the same counts."""
    import numpy as np

    from tankcd_cli.replay.plausibility import FITS, MotionChecks

    rng = np.random.default_rng(seed)
    n, vehicles = 400, 7
    who = rng.integers(0, vehicles, n)
    t = np.sort(rng.uniform(0, 100, n)).round(1)  # equal times too
    x = rng.normal(0, 40, n).cumsum() * rng.choice([0.1, 1.0, 10.0], n)  # some steps too fast
    y = rng.normal(0, 40, n).cumsum()
    yaw = rng.uniform(-180, 180, n) if seed % 2 else np.degrees(np.arctan2(np.gradient(y), np.gradient(x))) + 90
    line = np.arange(2, n + 2)
    names = tuple(f"V{v}" for v in range(vehicles))

    def chunked(check):
        cuts = np.sort(rng.choice(np.arange(1, n), 5, replace=False))
        for rows in np.split(np.arange(n), cuts):
            check.observe_rows(who[rows], t[rows], x[rows], y[rows], yaw[rows], line[rows], names)

    together = MotionChecks("x.csv")
    said = _said(together, chunked)
    alone_said = []
    for v in range(vehicles):
        rows = np.flatnonzero(who == v)
        alone = MotionChecks("x.csv", name=names[v])
        alone_said.append(_said(alone, lambda c: c.observe(t[rows], x[rows], y[rows], yaw[rows], line[rows])))
        for field in ("moving", "off", "first_off_line", "fast_warned", "turn_warned"):
            assert getattr(together, field)[v] == getattr(alone, field)[0], (v, field)
        assert (together.fits[:, v] == alone.fits[:, 0]).all()
    # each vehicle's warnings in its own order; the heading check's come last, once every row is seen
    heading = [w for w in said if "moving rows head" in w]
    assert sorted(w for w in said if w not in heading) == sorted(w for a in alone_said for w in a
                                                                 if "moving rows head" not in w)
    assert sorted(heading) == sorted(w for a in alone_said for w in a if "moving rows head" in w)
    assert len(FITS) == together.fits.shape[0]
    assert any(said), "the random exercise should trip at least one check"
