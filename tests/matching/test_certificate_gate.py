"""The certificate's gate (``matching.match.certificate_gate``) changes no answer: wherever it
proves a pose passes, the exact passes pass it too, and every pose it places is bit for bit the
pose the exact certificate gives, on planar, nearly planar and rough ground."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.gates import GateTally
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.matching.match import certificate_gate, certify, escalation_tolerance, match
from tankcd_cli.terrain.grid.surface import GridSurface
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")
X0, Y0 = 500_000.0, 4_500_000.0  # UTM-sized coordinates


def _grid(seed, spacing, slope_x, slope_y, noise, posts=48, steps=0.0):
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:posts, 0:posts]
    x, y = c * spacing, (posts - 1 - r) * spacing  # row 0 north
    z = 100.0 + slope_x * x + slope_y * y + noise * rng.standard_normal((posts, posts))
    if steps:
        z += steps * (x > posts * spacing / 2)  # a vertical step across the middle
    surface = GridSurface.from_arrays(z, np.zeros(z.shape, np.uint8),
                                      PostGrid(posts, posts, X0, Y0 + (posts - 1) * spacing, spacing, spacing))
    return surface, (posts - 1) * spacing


def _poses(seed, size, n=300):
    rng = np.random.default_rng(seed + 1)
    margin = 2.0  # some footprints reach past the grid's edge: the gate must leave them alone
    x = X0 + rng.uniform(margin, size - margin, n)
    y = Y0 + rng.uniform(margin, size - margin, n)
    yaw = rng.uniform(-np.pi, np.pi, n)
    yaw[:8] = [0.0, np.pi / 2, np.pi, -np.pi, np.pi / 4, -np.pi / 2, 1e-12, np.pi - 1e-12]  # wrap-around
    return x, y, yaw


def _same(a, b):
    for f in a.__dataclass_fields__:
        u, v = getattr(a, f), getattr(b, f)
        assert u.dtype == v.dtype and np.array_equal(u, v, equal_nan=True), f


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), spacing=st.sampled_from([0.5, 1.0, 2.0, 3.0]),
       slope_x=st.floats(-0.3, 0.3), slope_y=st.floats(-0.3, 0.3),
       noise=st.sampled_from([0.0, 1e-5, 1e-4, 1e-3, 3e-3, 1e-2, 0.1]), steps=st.sampled_from([0.0, 0.0, 0.02, 1.0]))
def test_gated_poses_are_the_exact_poses(seed, spacing, slope_x, slope_y, noise, steps):
    surface, size = _grid(seed, spacing, slope_x, slope_y, noise, steps=steps)
    x, y, yaw = _poses(seed, size)
    for matcher in ("wheel_stations", "four_point", "two_point"):
        tally = GateTally()
        gated = match(surface, T72, x, y, yaw, matcher=matcher, escalate=True, gates=tally)
        exact = match(surface, T72, x, y, yaw, matcher=matcher, escalate=True)
        _same(gated, exact)
        off = match(surface, T72, x, y, yaw, matcher=matcher, escalate=True, gates=GateTally(enabled=False))
        _same(off, exact)
        assert not GateTally(enabled=False).checked


@pytest.mark.parametrize("noise", [0.0, 1e-4, 1e-3])
def test_the_gate_skips_on_planar_ground(noise):
    """On planar ground (flat, or sloping 10 percent) within a millimetre, most key-point poses
    wholly on the terrain are proven: the gate does skip work."""
    surface, size = _grid(3, 2.0, 0.1, -0.05, noise)
    x, y, yaw = _poses(3, size)
    tally = GateTally()
    gated = match(surface, T72, x, y, yaw, matcher="wheel_stations", escalate=True, gates=tally)
    inside = np.abs(gated.plane).sum(axis=1) > 0
    assert tally.checked["certificate"] > 0
    assert tally.skipped["certificate"] >= 0.5 * inside.sum()


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), noise=st.floats(0.0, 0.02), slope=st.floats(-0.5, 0.5),
       tol_scale=st.floats(0.05, 2.0), att=st.floats(0.05, 2.0))
def test_every_proven_pose_passes_the_exact_certificate(seed, noise, slope, tol_scale, att):
    """Near the gate's limits (noise of the order of the tolerances, tolerances shrunk and
    grown), each pose the gate proves is one ``certify``'s exact passes pass."""
    surface, size = _grid(seed, 1.0, slope, -slope / 2, noise)
    x, y, yaw = _poses(seed, size, n=200)
    planes = match(surface, T72, x, y, yaw, matcher="wheel_stations", escalate=False, measure=False).plane
    tol = escalation_tolerance(T72) * tol_scale
    proven = certificate_gate(surface, T72, x, y, yaw, planes, tol, np.radians(att))
    exact = certify(surface, T72, x, y, yaw, planes, tol, att)
    assert not (proven & ~exact.passed).any()
