"""`tankcd tradeoff --quick`: the report runs, and its numbers are sane."""

import csv
import dataclasses
import math

import numpy as np
import pytest

from tankcd_cli.terrain import synthetic
from tankcd_cli.tradeoff import report as report_module
from tankcd_cli.tradeoff.report import pareto
from tankcd_cli.tradeoff.stages import QUICK, Point, angle_deg, tripod_planes

# --quick's inputs and every stage, timed fewer times: one timed run a variant, two pairs behind a
# ratio, a turn one call long (the assertions hold the report's shape and its counts, not its times)
FEWER_REPEATS = dataclasses.replace(QUICK, repeats=1, pair_repeats=2, turn_seconds=0.0)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    from click.testing import CliRunner

    from tankcd_cli.cli.main import cli

    out = tmp_path_factory.mktemp("tradeoff")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(report_module, "QUICK", FEWER_REPEATS)
        result = CliRunner().invoke(cli, ["tradeoff", "--quick", "--out", str(out)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    with open(out / "tradeoff.csv") as fh:
        rows = list(csv.DictReader(fh))
    return out, rows, result.output


def _values(rows, **match):
    return [r for r in rows if all(r[k] == v for k, v in match.items())]


def test_writes_the_three_files(report):
    out, rows, output = report
    assert (out / "tradeoff.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (out / "tradeoff.md").read_text()
    for heading in ("## curvature", "## matching", "## collision", "## internal", "Headline", "Machine:",
                    "## Sampling rate", "## What the gates skip"):
        assert heading in md
    assert "than reference" in output and ("x faster (pairs" in output or "within noise" in output)
    assert {r["stage"] for r in rows} == {"headline", "curvature", "matching", "collision", "internal", "rate",
                                          "gates"}
    assert "Not measured in quick mode" in md  # the corpus: tests/tradeoff/test_corpus.py holds it


def test_every_ratio_carries_its_spread(report):
    _, rows, _ = report
    ratios = [r for r in rows if r["measure"] in ("speedup", "escalation_cost", "time_saved_share",
                                                   "cost_vs_discrete")]
    assert len(ratios) == 3 + 5
    for r in ratios:
        assert float(r["spread_lo"]) <= float(r["value"]) <= float(r["spread_hi"]), r


def test_the_gates_change_no_output_and_say_what_share_they_skipped(report):
    """The patrol alone and a column of vehicles driving it: the same outputs with the gates off, a
    share in [0, 1] for each gate that ran (the certificate's on both, the pairs' on the column only),
    and the cost ratio inside its pairs' range."""
    out, rows, _ = report
    gates = _values(rows, stage="gates")
    cases = list(dict.fromkeys(r["case"] for r in gates))
    assert len(cases) == 2 and "a column of 4 vehicles" in cases[1]
    for case in cases:
        assert float(_values(gates, case=case, measure="outputs_identical")[0]["value"]) == 1.0
        shares = {r["variant"]: float(r["value"]) for r in _values(gates, case=case, measure="share_skipped")}
        assert "certificate" in shares and all(0.0 <= v <= 1.0 for v in shares.values())
        assert ("vehicle_pairs" in shares) == (case == cases[1])
        ratio = _values(gates, case=case, measure="cost_vs_no_gates")[0]
        assert float(ratio["spread_lo"]) <= float(ratio["value"]) <= float(ratio["spread_hi"])
    md = (out / "tradeoff.md").read_text()
    assert md.count("| the same |") == 2 and "**differ**" not in md


def test_the_column_is_the_trajectory_driven_by_each_vehicle_in_turn(tmp_path):
    """Read back by the project's reader: in time order, each vehicle's rows the route's own, shifted
    by its place in the column times the delay."""
    from tankcd_cli.io.trajectory import read_trajectory
    from tankcd_cli.tradeoff.gates import write_column

    t = np.arange(5) * 0.5
    route = {"t": t, "x": 500000 + t, "y": 4500000 - 2 * t, "yaw_deg": 10 * t, "turret_deg": -t, "gun_deg": t / 10}
    path = tmp_path / "column.csv"
    assert write_column(str(path), route, vehicles=3, delay=0.7) == 15
    chunks = list(read_trajectory(str(path)))
    got_t = np.concatenate([c.t for c in chunks])
    names = np.array(chunks[0].entity_names)[np.concatenate([c.entity for c in chunks])]
    assert np.all(np.diff(got_t) >= 0)
    for k in range(3):
        mine = names == f"v{k + 1}"
        np.testing.assert_allclose(got_t[mine], t + 0.7 * k, atol=1e-12)
        for key in ("x", "y", "yaw_deg", "turret_deg", "gun_deg"):
            np.testing.assert_allclose(np.concatenate([getattr(c, key) for c in chunks])[mine], route[key], atol=1e-9)


def test_outputs_that_differ_are_told_apart():
    """The comparison behind ``outputs_identical``: one pose bit, one event field, a NaN against a number."""
    from tankcd_cli.tradeoff.gates import same_outputs

    poses = {"x": np.array([1.0, np.nan]), "matcher": np.array(["auto", "auto"], dtype=object)}
    events = [{"step": 1, "kind": "terrain"}]
    assert same_outputs((poses, events, None), ({k: v.copy() for k, v in poses.items()}, [dict(events[0])], None))
    bumped = {**poses, "x": np.array([np.nextafter(1.0, 2.0), np.nan])}
    assert not same_outputs((poses, events, None), (bumped, events, None))
    assert not same_outputs((poses, events, None), ({**poses, "x": np.array([1.0, 0.0])}, events, None))
    assert not same_outputs((poses, events, None), (poses, [{"step": 1, "kind": "obstacle"}], None))


def test_the_rows_alone_miss_contacts_at_1_hz_and_no_more_at_50(report):
    out, rows, _ = report
    cases = list(dict.fromkeys(r["case"] for r in _values(rows, stage="rate")))
    assert [c.split(" at ")[1].split(" (")[0] for c in cases] == ["1 Hz", "2 Hz", "5 Hz", "10 Hz", "50 Hz"]

    def total(case, prefix):
        return sum(float(r["value"]) for r in _values(rows, stage="rate", case=case) if r["measure"].startswith(prefix))
    for case in cases:
        assert 0 <= total(case, "missed_") <= total(case, "contacts_") and total(case, "contacts_") > 0, case
    assert total(cases[0], "missed_") > 0  # 1 Hz rows, 5 m apart on the patrol, step over the scrapes
    assert total(cases[-1], "missed_") <= total(cases[0], "missed_")
    assert "| 1 Hz | 115 |" in (out / "tradeoff.md").read_text()


def test_errors_and_times_are_non_negative_and_finite(report):
    _, rows, _ = report
    for r in rows:
        if r["measure"] == "not_installed":
            continue
        value = float(r["value"])
        assert math.isfinite(value), r
        assert value >= 0, r
        if r["measure"].startswith("time_per"):
            assert 0 < float(r["spread_lo"]) <= value <= float(r["spread_hi"]), r


def test_each_truth_scores_zero_against_itself(report):
    _, rows, _ = report
    ref = [r for r in _values(rows, stage="matching", variant="reference") if "error" in r["measure"]]
    assert ref and all(float(r["value"]) == 0.0 for r in ref)
    exact = _values(rows, stage="internal", variant="exact", measure="disagreement")
    assert exact and float(exact[0]["value"]) == 0.0
    # the projection may raise false alarms but never misses (the paper's test is conservative)
    assert float(_values(rows, stage="internal", variant="projection", measure="missed_share")[0]["value"]) == 0.0
    # every tree layout is exact: it finds the brute-force contacts, only the work differs
    layouts = _values(rows, stage="collision", measure="disagreement_with_truth")
    assert len(layouts) >= 8 and all(float(r["value"]) == 0.0 for r in layouts)


def test_the_truths_are_independent_of_the_methods_they_judge(report):
    _, rows, _ = report
    truths = {r["stage"]: r["truth"] for r in rows if "jitter" not in r["measure"]}
    assert "closed-form" in truths["curvature"]
    assert "reference" in truths["matching"] and "brute force" in truths["collision"]
    assert "exact" in truths["internal"]
    # the accurate curvature method beats the paper's estimators on every analytic surface
    for case in {r["case"] for r in _values(rows, stage="curvature")}:
        err = {r["variant"]: float(r["value"]) for r in _values(rows, stage="curvature", case=case,
                                                               measure="error_median_interior")}
        assert err["jet"] < err["cotan"] and err["jet"] < err["sphere"], case
    # more key points, closer to the reference on uneven ground (the paper's ordering)
    uneven = [c for c in {r["case"] for r in _values(rows, stage="matching")} if ": uneven" in c]
    assert uneven
    for case in uneven:
        err = {r["variant"]: float(r["value"]) for r in _values(rows, stage="matching", case=case,
                                                               measure="height_error_median")}
        assert err["six_point"] < err["two_point"], case


def test_closed_form_curvature_agrees_with_finite_differences():
    """The curvature truth checked on its own: H from the closed form against H from f by differences."""
    h = 1e-3
    for field in (synthetic.gaussian_hill(2.0, 8.0), synthetic.sinusoid(0.8, 30.0, 24.0), synthetic.sphere_cap(150.0)):
        x, y = np.array([0.3, -4.1, 7.7]), np.array([1.2, 5.5, -2.0])
        f = field.f
        fx = (f(x + h, y) - f(x - h, y)) / (2 * h)
        fy = (f(x, y + h) - f(x, y - h)) / (2 * h)
        fxx = (f(x + h, y) - 2 * f(x, y) + f(x - h, y)) / h**2
        fyy = (f(x, y + h) - 2 * f(x, y) + f(x, y - h)) / h**2
        fxy = (f(x + h, y + h) - f(x + h, y - h) - f(x - h, y + h) + f(x - h, y - h)) / (4 * h * h)
        H = -((1 + fy**2) * fxx - 2 * fx * fy * fxy + (1 + fx**2) * fyy) / (2 * (1 + fx**2 + fy**2) ** 1.5)
        np.testing.assert_allclose(field.mean_curvature(x, y), H, rtol=1e-4, atol=1e-7)


def test_tripod_on_a_tilted_plane_is_exact():
    from tankcd_cli.vehicle import vehicle_preset

    a, b = 0.05, -0.03
    rows, cols = np.mgrid[0:60, 0:60]
    surface = synthetic.surface_of(synthetic.dem_terrain(10 + a * cols + b * rows))
    v = vehicle_preset("t72")
    x, y, yaw = np.array([30.0, 25.0]), np.array([30.0, 33.0]), np.array([0.3, -2.9])
    plane, on = tripod_planes(surface, v, x, y, yaw)
    assert on.all()
    # the plane z = p0 + p1 u + p2 v in the heading frame: the slope rotated into that frame
    c, s = np.cos(yaw), np.sin(yaw)
    np.testing.assert_allclose(plane[:, 0], 10 + a * x + b * y, atol=1e-9)
    np.testing.assert_allclose(plane[:, 1], a * c + b * s, atol=1e-12)
    np.testing.assert_allclose(plane[:, 2], -a * s + b * c, atol=1e-12)


def test_angle_between_unit_vectors():
    u = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.6, 0.0, 0.8]])
    v = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    np.testing.assert_array_equal(angle_deg(u, v), [0.0, 90.0, 0.0])
    tiny = np.array([[np.sin(1e-9), 0.0, np.cos(1e-9)]])
    np.testing.assert_allclose(angle_deg(tiny, u[:1]), np.degrees(1e-9), rtol=1e-6)


def test_pareto_front():
    pts = [Point("s", name, t, t, t, e) for name, t, e in
           (("slow exact", 10, 0.0), ("fast rough", 1, 0.5), ("dominated", 5, 0.6), ("middle", 3, 0.1))]
    assert [p.variant for p in pareto(pts)] == ["fast rough", "middle", "slow exact"]
