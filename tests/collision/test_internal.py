"""Gun barrel against the rear drums: exact cylinder test, the paper's projection test, the envelope."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.collision.internal import barrel, drums, elevation_envelope, gun_hits_drums
from tankcd_cli.geometry.cylinders import cylinders_intersect, gjk_distance, projections_overlap
from tankcd_cli.vehicle import vehicle_preset

X, Y, Z = np.eye(3)


def exact(cA, aA, hA, rA, cB, aB, hB, rB):
    return bool(cylinders_intersect(np.array([cA], float), np.array([aA], float), hA, rA, cB, aB, hB, rB)[0])


def projected(cA, aA, hA, rA, cB, aB, hB, rB):
    return bool(projections_overlap(np.array([cA], float), np.array([aA], float), hA, rA, cB, aB, hB, rB)[0])


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_crossed_axes_just_over_touching_through(scale):
    """A barrel along x above a drum along y: they meet when the axes are rA + rB apart."""
    rA, rB = 0.11 * scale, 0.30 * scale
    drum = (np.zeros(3), Y, 0.44 * scale, rB)
    for gap, expected in ((1e-3 * scale, False), (0.0, True), (-1e-3 * scale, True), (-0.3 * scale, True)):
        centre = np.array([0.0, 0.0, rA + rB + gap])
        assert exact(centre, X, 3 * scale, rA, *drum) is expected, gap
        assert projected(centre, X, 3 * scale, rA, *drum) or not expected


def test_parallel_axes():
    for d, expected in ((0.41 + 1e-6, False), (0.41, True), (0.2, True)):
        assert exact(np.array([d, 0.0, 0.0]), Y, 0.5, 0.11, np.zeros(3), Y, 0.44, 0.30) is expected
    # parallel, side by side but offset along the axis beyond both ends
    assert not exact(np.array([0.2, 1.0, 0.0]), Y, 0.5, 0.11, np.zeros(3), Y, 0.44, 0.30)
    assert exact(np.array([0.2, 0.94, 0.0]), Y, 0.5, 0.11, np.zeros(3), Y, 0.44, 0.30)


def test_barrel_end_cap_against_drum_side():
    rB = 0.3
    # barrel along x ending at x = -rB - gap, its flat cap facing the drum's curved side
    for gap, expected in ((1e-4, False), (0.0, True), (-1e-3, True)):
        centre = np.array([-rB - gap - 1.0, 0.0, 0.0])
        assert exact(centre, X, 1.0, 0.11, np.zeros(3), Y, 0.44, rB) is expected


def test_perpendicular_skew_rims():
    """Rim against rim: the barrel's end just beyond the drum's end, diagonally."""
    hB, rB = 0.44, 0.30
    corner = np.array([0.0, hB, rB])  # top of the drum's rim at its left end
    off = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    for gap, expected in ((1e-3, False), (-1e-3, True)):
        # a thin barrel along x whose surface passes the rim at distance gap
        centre = corner + off * (0.05 + gap)
        assert exact(centre, X, 1.0, 0.05, np.zeros(3), Y, hB, rB) is expected


def sample_solid(c, a, h, r, n=14):
    a = a / np.linalg.norm(a)
    u = np.cross(a, X if abs(a[0]) < 0.9 else Y)
    u /= np.linalg.norm(u)
    v = np.cross(a, u)
    s, rho, phi = np.meshgrid(np.linspace(-h, h, n), np.linspace(0, r, n // 2), np.linspace(0, 2 * np.pi, n, endpoint=False))
    return c + s.reshape(-1, 1) * a + (rho * np.cos(phi)).reshape(-1, 1) * u + (rho * np.sin(phi)).reshape(-1, 1) * v


def inside(points, c, a, h, r):
    a = a / np.linalg.norm(a)
    d = points - c
    along = d @ a
    radial = np.linalg.norm(d - np.outer(along, a), axis=1)
    return (np.abs(along) <= h) & (radial <= r)


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_property_exact_against_dense_sampling_and_projection_conservative(seed):
    rng = np.random.default_rng(seed)
    cA, cB = rng.normal(0, 0.6, 3), rng.normal(0, 0.6, 3)
    aA, aB = rng.normal(0, 1, 3), rng.normal(0, 1, 3)
    aA /= np.linalg.norm(aA)
    aB /= np.linalg.norm(aB)
    hA, hB, rA, rB = rng.uniform(0.1, 1.5, 4)
    hit = exact(cA, aA, hA, rA, cB, aB, hB, rB)
    # a sampled point of A inside B proves contact; the exact test must see it
    if inside(sample_solid(cA, aA, hA, rA), cB, aB, hB, rB).any() or inside(sample_solid(cB, aB, hB, rB), cA, aA, hA, rA).any():
        assert hit
    # and its distance is no more than the sampled one, and not far below it
    d = gjk_distance(cA, aA, hA, rA, cB, aB, hB, rB, 0.0, 0.0, 0.0, 1e-9, False)
    pa, pb = sample_solid(cA, aA, hA, rA, 24), sample_solid(cB, aB, hB, rB, 24)
    from scipy.spatial import cKDTree

    sampled = cKDTree(pb).query(pa)[0].min()
    assert d <= sampled + 1e-9
    assert d >= sampled - 0.5 * max(hA, hB, rA, rB)
    # symmetric, and the paper's projection never misses a real collision
    assert exact(cB, aB, hB, rB, cA, aA, hA, rA) == hit
    if hit:
        assert projected(cA, aA, hA, rA, cB, aB, hB, rB)


def test_t72_reproduces_the_papers_situation():
    t72 = vehicle_preset("t72")
    cases = {(180.0, -6.0): True, (180.0, 5.0): False, (0.0, -6.0): False, (90.0, -6.0): False, (170.0, -6.0): True}
    for (az, el), expected in cases.items():
        for method in ("exact", "projection"):
            got = gun_hits_drums(t72, np.radians([az]), np.radians([el]), method).any()
            assert got == expected or (method == "projection" and got), (az, el, method)


def test_no_drums_nothing_to_hit():
    m1 = vehicle_preset("m1")
    assert drums(m1) == [] and not gun_hits_drums(m1, np.radians([180.0]), np.radians([-10.0])).any()


def test_envelope_is_the_bisected_limit():
    t72 = vehicle_preset("t72")
    env = elevation_envelope(t72, np.arange(0, 360, 5.0))
    az, lim = env["azimuth"], env["min_elevation"]
    assert env["checked"].all()
    front = (az < 90) | (az > 270)
    assert (lim[front] == t72.gun_min_deg).all()
    rear = env["limited"]
    assert rear.any() and (np.abs(az[rear] - 180) < 60).all()
    assert (lim[rear] > t72.gun_min_deg).all() and (lim[rear] < t72.gun_max_deg).all()
    # the limit is clear and 0.01 deg below it touches
    clear = gun_hits_drums(t72, np.radians(az[rear]), np.radians(lim[rear])).any(axis=1)
    below = gun_hits_drums(t72, np.radians(az[rear]), np.radians(lim[rear] - 0.011)).any(axis=1)
    assert not clear.any() and below.all()
    # symmetric about the rear: the drums are mirror images
    np.testing.assert_allclose(lim[az == 170.0], lim[az == 190.0], atol=0.011)


def test_barrel_kinematics():
    t72 = vehicle_preset("t72")
    c, a, h, r = barrel(t72, np.radians([0.0, 90.0]), np.radians([0.0, 10.0]))
    muzzle = c + h * a
    assert muzzle[0] == pytest.approx([t72.turret_x + t72.trunnion_forward + t72.gun_length, 0, t72.trunnion_height])
    assert muzzle[1, 0] == pytest.approx(t72.turret_x) and muzzle[1, 2] > t72.trunnion_height


def test_envelope_command_csv_and_png(run, tmp_path):
    result = run("envelope", "--step", "10", "--png", "env.png")
    assert result.exit_code == 0, result.stderr
    lines = result.stdout.strip().splitlines()
    assert lines[0] == "azimuth_deg,min_elevation_deg,limited_by,checked"
    rows = [line.split(",") for line in lines[1:]]
    assert len(rows) == 36
    rear = [r for r in rows if float(r[0]) == 180.0][0]
    assert rear[2].startswith("drum") and -6.0 < float(rear[1]) < 0.0 and rear[3] == "true"
    front = [r for r in rows if float(r[0]) == 0.0][0]
    assert front[1:3] == ["-6.00", "gun"]
    assert (tmp_path / "env.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    m1 = run("envelope", "--vehicle", "m1", "--step", "30")
    assert all(line.endswith(",gun,true") for line in m1.stdout.strip().splitlines()[1:])


# --- along the angle path between two rows ------------------------------------------------------

def _dense_first(vehicle, az0, daz, el0, dele, step_deg=0.0005):
    """The oracle: the exact test at steps of step_deg along the path; the first fraction that hits."""
    turn = max(abs(daz), abs(dele))
    n = max(int(np.ceil(np.degrees(turn) / step_deg)), 1)
    s = np.linspace(0, 1, n + 1)
    hit = gun_hits_drums(vehicle, az0 + s * daz, el0 + s * dele).any(axis=1)
    return s[np.argmax(hit)] if hit.any() else None


def test_the_turret_swinging_over_the_rear_meets_the_drums_where_the_envelope_says():
    from tankcd_cli.collision.internal import first_gun_contacts
    from tankcd_cli.geometry.motion import shorter_arc_deg

    t72 = vehicle_preset("t72")
    change = float(shorter_arc_deg(150.0, -150.0))  # 60 deg, through 180
    found, s, drum = first_gun_contacts(t72, np.radians([150.0]), np.radians([change]), np.radians([-6.0]), [0.0])
    assert found[0] and drum[0] == 0  # the left drum first, turning counter-clockwise over the rear
    first = 150.0 + change * s[0]
    # the envelope: the lowest safe elevation rises above -6 deg there
    env = elevation_envelope(t72, np.array([first - 0.01, first + 0.01]))
    assert env["min_elevation"][0] <= -6.0 < env["min_elevation"][1]
    assert first == pytest.approx(161.68, abs=0.01)


@settings(max_examples=40, deadline=None)
@given(st.floats(-180, 180), st.floats(-90, 90), st.floats(-6, 14), st.floats(-20, 20))
def test_the_first_contact_along_a_path_is_the_dense_sweeps_to_a_hundredth_of_a_degree(az0, daz, el0, dele):
    from tankcd_cli.collision.internal import first_gun_contacts

    t72 = vehicle_preset("t72")
    a0, da, e0, de = np.radians([az0, daz, el0, dele])
    found, s, _ = first_gun_contacts(t72, [a0], [da], [e0], [de])
    dense = _dense_first(t72, a0, da, e0, de)
    turn = np.degrees(max(abs(da), abs(de)))
    if dense is None:
        assert not found[0]
        return
    assert found[0]
    assert abs(s[0] - dense) * turn <= 0.01


def test_paths_that_start_touching_stop_at_zero_and_vehicles_without_drums_never_touch():
    from tankcd_cli.collision.internal import first_gun_contacts

    t72, m1 = vehicle_preset("t72"), vehicle_preset("m1")
    found, s, _ = first_gun_contacts(t72, np.radians([180.0]), [0.1], np.radians([-6.0]), [0.0])
    assert found[0] and s[0] == 0.0
    found, s, drum = first_gun_contacts(m1, np.radians([150.0]), np.radians([60.0]), np.radians([-10.0]), [0.0])
    assert not found.any() and np.isnan(s).all() and (drum == -1).all()
    found, _, _ = first_gun_contacts(t72, np.radians([90.0]), [0.0], np.radians([-6.0]), [0.0])  # no motion
    assert not found[0]


def test_envelope_summary_of_a_vehicle_with_and_without_drums():
    from tankcd_cli.collision.internal import envelope_summary

    az = np.arange(0.0, 360.0, 1.0)
    m1 = vehicle_preset("m1")
    facts = envelope_summary(m1, elevation_envelope(m1, az), 1.0)
    assert facts == {"fuel_drums": False, "gun_min_deg": -10.0, "limited_deg": 0.0, "blocked_deg": 0.0,
                     "worst_deg": None}
    t72 = vehicle_preset("t72")
    facts = envelope_summary(t72, elevation_envelope(t72, az), 1.0)
    assert facts["fuel_drums"] and facts["limited_deg"] == 37.0 and facts["blocked_deg"] == 0.0
    assert t72.gun_min_deg < facts["worst_deg"] < 0
