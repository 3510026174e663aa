"""Matchers against independent truths: analytic planes, brute-force supports, dense sampling."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.geometry.support_plane import support_plane, support_plane_brute_force
from tankcd_cli.matching.match import AUTO_RULE, CLASS_NAMES, MATCHERS, OFF, OK, PARTLY_OFF, match, patch_quads
from tankcd_cli.geometry.pose import rotation_matrix, wrap_angle
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")
UTM = (500_000.0, 4_500_000.0)


def plane_surface(a=0.12, b=-0.07, c=30.0, mesh="dem", offset=UTM):
    if mesh == "dem":
        n = 51
        xs = np.arange(n) * 1.0
        Z = c + a * (xs[None, :] - 25) + b * (xs[:, None] - 25)
        return S.surface_of(S.dem_terrain(Z, origin=(offset[0] - 25, offset[1] - 25)))
    V, F, _ = S.jittered_mesh(S.plane(a, b, c), 25.0, 1.0, offset=(offset[0], offset[1], 0.0))
    return S.surface_of(S.mesh_terrain(V, F))


@pytest.mark.parametrize("mesh", ["dem", "jittered"])
@pytest.mark.parametrize("matcher", MATCHERS + ("auto",))
def test_tilted_plane_is_exact(mesh, matcher):
    a, b = 0.12, -0.07
    surface = plane_surface(a, b, mesh=mesh)
    rng = np.random.default_rng(0)
    n = 300
    x = UTM[0] + rng.uniform(-15, 15, n)
    y = UTM[1] + rng.uniform(-15, 15, n)
    yaw = np.concatenate([rng.uniform(-np.pi, np.pi, n - 4), [np.pi, -np.pi, 0.0, np.pi / 2]])
    p = match(surface, T72, x, y, yaw, matcher)
    assert (p.status == OK).all()
    np.testing.assert_allclose(p.position[:, 2], 30 + a * (x - UTM[0]) + b * (y - UTM[1]), atol=1e-9)
    normal = np.array([-a, -b, 1.0]) / np.linalg.norm([-a, -b, 1.0])
    np.testing.assert_allclose(p.rotation[:, :, 2], np.broadcast_to(normal, (n, 3)), atol=1e-9)
    # the hull's x axis points along the heading, seen from above
    fwd = p.rotation[:, :2, 0]
    heading = np.arctan2(fwd[:, 1], fwd[:, 0])
    np.testing.assert_allclose(np.cos(heading - yaw), 1.0, atol=1e-12)
    assert np.nanmax(p.penetration) < 1e-9 and np.nanmax(p.gap) < 1e-9


def test_exactly_flat_ground():
    surface = S.surface_of(S.dem_terrain(np.full((30, 30), 250.0), origin=UTM))
    x, y = UTM[0] + 15 + np.arange(5), UTM[1] + 15 + np.zeros(5)
    for m in MATCHERS:
        p = match(surface, T72, x, y, np.linspace(-np.pi, np.pi, 5), m)
        assert (p.position[:, 2] == 250.0).all()
        assert (p.roll == 0).all() and (p.pitch == 0).all()
        assert (p.penetration == 0).all() and (p.gap == 0).all()


def test_signs_follow_rep103():
    """Uphill ahead: nose up, negative pitch. Ground falling to the right: positive roll."""
    up_east = plane_surface(0.1, 0.0, offset=(0, 0))
    p = match(up_east, T72, [0.0], [0.0], [0.0], "reference")
    assert p.pitch[0] == pytest.approx(-np.arctan(0.1)) and abs(p.roll[0]) < 1e-12
    # heading north on ground rising to the east: the right side (east) is up, roll negative
    p = match(up_east, T72, [0.0], [0.0], [np.pi / 2], "reference")
    assert p.roll[0] == pytest.approx(-np.arcsin(0.1 / np.sqrt(1.01))) and abs(p.pitch[0]) < 1e-12


def test_heading_wraps_around():
    surface = S.surface_of(S.dem_terrain(np.random.default_rng(1).normal(0, 0.2, (40, 40)).cumsum(axis=1) * 0.2))
    for m in MATCHERS:
        a = match(surface, T72, [20.0, 20.0, 20.0], [20.0] * 3, [np.pi, -np.pi, 3 * np.pi], m)
        np.testing.assert_allclose(a.quaternion[1:], np.broadcast_to(a.quaternion[0], (2, 4)), atol=1e-12)
        np.testing.assert_allclose(a.position[1:], np.broadcast_to(a.position[0], (2, 3)), atol=1e-12)
        near = match(surface, T72, [20.0, 20.0], [20.0, 20.0], np.radians([179.999, -179.999]), m)
        assert abs(near.position[0, 2] - near.position[1, 2]) < 1e-3
    assert wrap_angle(np.array([np.pi, -np.pi, 3 * np.pi]))[0] == np.pi


def test_utm_offset_changes_nothing():
    rng = np.random.default_rng(5)
    Z = rng.normal(0, 0.3, (40, 40))
    local = S.surface_of(S.dem_terrain(Z, origin=(0.0, 0.0)))
    utm = S.surface_of(S.dem_terrain(Z, origin=UTM))
    x, y, yaw = rng.uniform(8, 30, 50), rng.uniform(8, 30, 50), rng.uniform(-4, 4, 50)
    for m in MATCHERS:
        a = match(local, T72, x, y, yaw, m)
        b = match(utm, T72, x + UTM[0], y + UTM[1], yaw, m)
        np.testing.assert_allclose(b.position[:, 2], a.position[:, 2], atol=1e-9)
        np.testing.assert_allclose(b.quaternion, a.quaternion, atol=1e-9)


def test_partly_and_entirely_off_the_terrain():
    surface = S.surface_of(S.dem_terrain(np.full((21, 21), 5.0)))
    # inside; the front hanging off the east edge; the centre past the edge (nothing there can
    # carry the hull: it would tip over); far away
    x = np.array([10.0, 19.0, 21.5, 100.0])
    p = match(surface, T72, x, np.full(4, 10.0), np.zeros(4), "two_point")
    assert p.status.tolist() == [OK, PARTLY_OFF, OFF, OFF]
    assert p.matcher[1] == MATCHERS.index("reference")  # the key point off the edge: reference over what is there
    assert p.position[1, 2] == pytest.approx(5.0) and 0 < p.covered[1] < 1
    assert np.isnan(p.position[2:, 2]).all() and np.isnan(p.quaternion[2:]).all()
    assert np.isfinite(p.position[:2]).all()


@pytest.mark.parametrize("rule", [dict(AUTO_RULE), {"flat": "two_point", "general": "four_point", "uneven": "six_point"}])
def test_auto_follows_the_region_classes(rule, monkeypatch):
    """Each pose gets the matcher the rule gives its class: the shipped rule and the paper's."""
    monkeypatch.setattr("tankcd_cli.matching.match.AUTO_RULE", rule)
    x = np.arange(-40, 41, 1.0)
    X, Y = np.meshgrid(x, x)
    r = np.hypot(X - 20, Y)
    Z = np.where(r < 5, -1.5 * (1 - (r / 5) ** 2) ** 2, 0.0) + 0.4 * np.exp(-((r - 5) / 1.5) ** 2)
    surface = S.surface_of(S.dem_terrain(Z, origin=(-40.0, -40.0)))
    p = match(surface, T72, [-25.0, 20.0], [0.0, 0.0], [0.3, 1.0], "auto", escalate=False)  # the plain rule
    assert [CLASS_NAMES[c] for c in p.region] == ["flat", "uneven"]
    assert [MATCHERS[m] for m in p.matcher] == [rule["flat"], rule["uneven"]]


# --- the reference: exact, never penetrating, the lowest such plane ---------------------

def rough_surface(seed, dem=True):
    rng = np.random.default_rng(seed)
    if dem:
        Z = np.cumsum(rng.normal(0, 0.08, (36, 36)), axis=0) + rng.normal(0, 0.05, (36, 36))
        return S.surface_of(S.dem_terrain(Z, spacing=0.8))
    V, F, _ = S.jittered_mesh(S.sinusoid(0.8, 9.0, 7.0), 14.0, 0.8, seed=seed)
    V[:, 2] += rng.normal(0, 0.05, len(V))
    V[:, :2] += 14.0
    return S.surface_of(S.mesh_terrain(V, F))


def dense_patch_samples(vehicle, per_metre=40):
    """Points of both contact rectangles in the vehicle's ground plane, spacing 2.5 cm."""
    h, g, w = vehicle.track_length / 2, vehicle.track_gauge / 2, vehicle.track_width / 2
    us = np.linspace(-h, h, int(2 * h * per_metre) + 1)
    vs = np.linspace(-w, w, int(2 * w * per_metre) + 1)
    U, V = np.meshgrid(us, vs)
    return np.vstack([np.column_stack([U.ravel(), V.ravel() + g]), np.column_stack([U.ravel(), V.ravel() - g])])


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 10_000), st.booleans())
def test_property_reference_never_penetrates_and_is_lowest(seed, dem):
    surface = rough_surface(seed, dem)
    rng = np.random.default_rng(seed)
    n = 6
    x, y, yaw = rng.uniform(11, 17, n), rng.uniform(11, 17, n), rng.uniform(-np.pi, np.pi, n)
    p = match(surface, T72, x, y, yaw, "reference")
    assert (p.status == OK).all()
    samples = dense_patch_samples(T72)
    for i in range(n):
        R = p.rotation[i]
        # the hull's ground plane, seen from above: sample it with the hull's own rotation
        world = samples @ R[:2, :2].T + [x[i], y[i]]
        ground, _, on = surface.height_normal(world[:, 0], world[:, 1])
        a, b, c = p.plane[i]
        co, si = np.cos(yaw[i]), np.sin(yaw[i])
        du, dv = world[:, 0] - x[i], world[:, 1] - y[i]
        u, v = co * du + si * dv, -si * du + co * dv
        height = a + b * u + c * v
        assert on.all()
        sampled = (ground - height).max()
        # the pose reports its own penetration honestly: the dense samples find no more than it says,
        # and where the hull tilts less than a tank can (30 degrees) the tilt settles and it is nil
        assert sampled <= p.penetration[i] + 1e-9
        if np.degrees(np.arccos(R[2, 2])) < 30:
            assert sampled <= 1e-7 and p.penetration[i] <= 1e-7
        # and no lower plane over the centre would do: the brute-force support of a sample subset
        # lies at most a sampling error below it
        sub = rng.choice(len(u), 60, replace=False)
        lower = support_plane_brute_force(u[sub], v[sub], ground[sub])
        assert lower <= a + 1e-9


def test_reference_matches_a_dense_lp():
    """The exact reference and an LP over 2.5 cm samples of the patches agree to the sampling error."""
    surface = rough_surface(3)
    p = match(surface, T72, [14.0], [14.0], [0.7], "reference", tilt_iterations=4)
    R = p.rotation[0]
    samples = dense_patch_samples(T72)
    world = samples @ R[:2, :2].T + [14.0, 14.0]
    ground, _, _ = surface.height_normal(world[:, 0], world[:, 1])
    co, si = np.cos(0.7), np.sin(0.7)
    du, dv = world[:, 0] - 14.0, world[:, 1] - 14.0
    u, v = co * du + si * dv, -si * du + co * dv
    a, b, c, status = support_plane(u, v, ground, len(u), 1e-9)
    assert status == 0
    assert a <= p.plane[0, 0] + 1e-9
    assert p.plane[0, 0] - a < 0.02  # 2.5 cm sampling of 0.8 m cells


@settings(max_examples=80, deadline=None)
@given(st.integers(3, 30), st.integers(0, 2**31 - 1), st.booleans())
def test_property_support_plane_matches_brute_force(n, seed, quantize):
    rng = np.random.default_rng(seed)
    u = np.r_[rng.uniform(-2, 2, n), -2, 2, 2, -2]
    v = np.r_[rng.uniform(-1.5, 1.5, n), -1.5, -1.5, 1.5, 1.5]
    z = rng.normal(0, 0.3, n + 4)
    if quantize:
        z = np.round(z, 1)  # many coplanar ties
    a, b, c, status = support_plane(u, v, z, len(u), 1e-12)
    assert status == 0
    assert (a + b * u + c * v - z).min() >= -1e-9
    assert a == pytest.approx(support_plane_brute_force(u, v, z), abs=1e-9)


# --- hard cases along paths ------------------------------------------------------------

@pytest.mark.parametrize("heading", [0.0, 30.0, 60.0, 89.0])
def test_knife_edge_crest_along_a_path(heading):
    x = np.arange(-30, 30.01, 0.5)
    Z = 10 - 0.3 * np.abs(x)[None, :] + 0 * x[:, None]
    surface = S.surface_of(S.dem_terrain(Z, origin=(-30.0, -30.0), spacing=0.5))
    h = np.radians(heading)
    s = np.linspace(-8, 8, 161)
    px, py = s * np.cos(h), s * np.sin(h)
    for m in MATCHERS:
        p = match(surface, T72, px, py, np.full_like(s, h), m)
        assert np.isfinite(p.position).all() and np.isfinite(p.quaternion).all()
        # height changes continuously: no faster than the slope along the path
        assert np.abs(np.diff(p.position[:, 2])).max() <= 0.3 * 0.1 * np.cos(h) + 1e-9
    ref = match(surface, T72, px, py, np.full_like(s, h), "reference")
    assert np.nanmax(ref.penetration) < 1e-9
    tilt = np.degrees(np.arccos(ref.rotation[:, 2, 2]))
    assert tilt.max() <= np.degrees(np.arctan(0.3)) + 1e-6
    # the rigid hull see-saws once over the crest (through the balanced middle): at most two jumps
    normal = ref.rotation[:, :, 2]
    turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", normal[1:], normal[:-1]), -1, 1)))
    assert (turn > 1.0).sum() <= 2


def test_ditch_as_wide_as_the_contact_length_is_bridged():
    L = T72.track_length
    x = np.arange(-20, 20.01, 0.25)
    X, Y = np.meshgrid(x, x)
    Z = np.where(np.abs(X) < L / 2, -1.5, 0.0)  # a vertical-walled ditch, exactly L wide
    surface = S.surface_of(S.dem_terrain(Z, origin=(-20.0, -20.0), spacing=0.25))
    s = np.linspace(-6, 6, 121)
    ref = match(surface, T72, s, np.zeros_like(s), np.zeros_like(s), "reference")
    assert np.isfinite(ref.position).all()
    assert np.nanmax(ref.penetration) < 1e-9
    assert ref.position[:, 2].min() > -1.5 - 1e-9  # a hull longer than... rests on the lips or the floor, never below
    assert np.abs(np.diff(ref.position[:, 2])).max() < 1.6


def test_vertical_step_under_one_track():
    x = np.arange(-15, 15.01, 0.25)
    X, Y = np.meshgrid(x, x)
    Z = np.where(Y > 0.5, 0.3, 0.0)  # a 30 cm step under the left track only
    surface = S.surface_of(S.dem_terrain(Z, origin=(-15.0, -15.0), spacing=0.25))
    for m in MATCHERS:
        p = match(surface, T72, [0.0], [0.0], [0.0], m)
        assert np.isfinite(p.position).all()
    ref = match(surface, T72, [0.0], [0.0], [0.0], "reference")
    assert ref.roll[0] > 0  # left side up is right side down: positive roll
    assert ref.penetration[0] < 1e-9


def test_errors_ordered_as_the_paper_claims():
    """On uneven ground the six-point match is closer to the reference than four, and four than two;
    and sampling every road-wheel station at both track edges closer still."""
    raw = S.dem_terrain(np.cumsum(np.random.default_rng(8).normal(0, 0.08, (120, 120)), axis=1)
                        + 0.8 * np.sin(np.arange(120) / 3.0)[:, None], spacing=0.5)
    surface = S.surface_of(raw)
    rng = np.random.default_rng(9)
    n = 3000
    x, y, yaw = rng.uniform(5, 55, n), rng.uniform(5, 55, n), rng.uniform(-np.pi, np.pi, n)
    ref = match(surface, T72, x, y, yaw, "reference")
    errs = {}
    for m in MATCHERS[:4]:
        p = match(surface, T72, x, y, yaw, m)
        errs[m] = (np.median(np.abs(p.position[:, 2] - ref.position[:, 2])),
                   np.median(np.arccos(np.clip(np.einsum("ij,ij->i", p.rotation[:, :, 2], ref.rotation[:, :, 2]), -1, 1))),
                   np.median(p.penetration))
    for k in range(3):
        assert errs["two_point"][k] > errs["four_point"][k] > errs["six_point"][k] > errs["wheel_stations"][k], errs


def test_patch_quads_are_the_tilted_rectangles_seen_from_above():
    roll, pitch = np.array([0.2]), np.array([-0.3])
    q = patch_quads(T72, roll, pitch)[0]
    R = rotation_matrix(roll, pitch, np.array([0.0]))[0]
    h, g, w = T72.track_length / 2, T72.track_gauge / 2, T72.track_width / 2
    corner = np.array([h, g + w, 0.0])
    np.testing.assert_allclose(q[0, 2], (R @ corner)[:2], atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([0.25, 0.5, 1.0, 3.0]), st.booleans())
def test_property_dem_arithmetic_equals_clipping_every_triangle(seed, spacing, holes):
    """The footprint pass reads full DEM cells by arithmetic; clipping every triangle (the general
    path, used for meshes) is the oracle: same supporting planes, penetration and coverage."""
    from tankcd_cli.matching.match import patch_quads

    rng = np.random.default_rng(seed)
    n = int(40 / spacing)
    Z = np.cumsum(rng.normal(0, 0.1 * spacing, (n, n)), axis=1) + np.round(rng.normal(0, 0.05, (n, n)), 1)
    if holes:
        Z[rng.integers(0, n, 3), rng.integers(0, n, 3)] = np.nan  # NODATA posts: those patches take the general path
    surface = S.surface_of(S.dem_terrain(Z, spacing=spacing, origin=(500_000.0, 4_500_000.0)))
    m = 300
    x = 500_000 + rng.uniform(-4, 44, m)
    y = 4_500_000 + rng.uniform(-4, 44, m)
    x[:40] = 500_000 + np.round(rng.uniform(6, 34, 40) / spacing) * spacing  # on posts, axis-aligned
    y[:40] = 4_500_000 + np.round(rng.uniform(6, 34, 40) / spacing) * spacing
    yaw = rng.uniform(-np.pi, np.pi, m)
    yaw[:40] = rng.choice([0.0, np.pi / 2, np.pi / 4, -np.pi, 3 * np.pi / 4], 40)
    quads = patch_quads(T72, rng.normal(0, 0.1, m), rng.normal(0, 0.1, m))
    planes = np.column_stack([rng.normal(0, 1, m), rng.normal(0, 0.1, m), rng.normal(0, 0.1, m)])
    queries = {0: lambda exact: surface.support_plane_under(x, y, yaw, quads, exact_cells=exact),
               1: lambda exact: surface.highest_over_patches(x, y, yaw, quads, planes, exact_cells=exact)}
    for mode in (0, 1):
        fast, slow = queries[mode](True), queries[mode](False)
        np.testing.assert_array_equal(fast[2], slow[2])
        np.testing.assert_allclose(fast[1], slow[1], atol=1e-12)
        if mode == 1:
            np.testing.assert_allclose(fast[0], slow[0], atol=1e-9, equal_nan=True)
            continue
        # the lowest supporting plane's height over the centre is unique; its tilt is not where the
        # centre lies on a ridge of the ground's upper hull (a see-saw): there both tilts must support
        np.testing.assert_allclose(fast[0][:, 0], slow[0][:, 0], atol=1e-9, equal_nan=True)
        differ = np.flatnonzero(~np.isclose(fast[0], slow[0], atol=1e-9, equal_nan=True).all(axis=1))
        for planes_found in (fast[0][differ], slow[0][differ]):
            above, _, _ = surface.highest_over_patches(x[differ], y[differ], yaw[differ], quads[differ], planes_found)
            assert (above <= 1e-9).all()
