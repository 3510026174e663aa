"""The compiled support-plane walk: its types and validation, zero divisors, the same plane from
any start as from level, against brute force."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.geometry.support_plane import support_plane, support_plane_brute_force, support_planes_fixed
from tankcd_cli.tolerances import EPS_XY


def test_support_plane_types_and_validation():
    u = np.array([-1.0, 1.0, 1.0, -1.0])
    v = np.array([-1.0, -1.0, 1.0, 1.0])
    z = np.array([0.0, 0.1, 0.2, 0.1])
    a, b, c, st = support_plane(u, v, z, 4, 1e-9)
    assert isinstance(a, float) and isinstance(st, int) and st == 0
    assert a == pytest.approx(support_plane_brute_force(u, v, z))
    assert np.isnan(support_plane(u, v, z, 0, 1e-9)[0]) and support_plane(u, v, z, 0, 1e-9)[3] == 1
    assert support_plane([0, 1, 2, 3], v.tolist(), z, 4, 1e-9)[3] in (0, 2)  # lists and ints are converted
    with pytest.raises(ValueError):
        support_plane(u, v, z, 5, 1e-9)
    planes, status = support_planes_fixed(u, v, np.tile(z, (7, 1))[:, ::1], 1e-9)
    assert planes.shape == (7, 3) and status.dtype == np.int64 and (status == 0).all()
    empty, st0 = support_planes_fixed(u, v, np.empty((0, 4)), 1e-9)
    assert empty.shape == (0, 3) and st0.shape == (0,)


def test_zero_divisors_raise_zero_division_error():
    # a negative eps lets a point level with p (d == 0) into the division
    with pytest.raises(ZeroDivisionError):
        support_plane(np.array([1.0, 1.0]), np.array([0.0, 0.0]), np.array([1.0, 0.0]), 2, -1e-3)
    with pytest.raises(ZeroDivisionError):
        support_planes_fixed(np.array([1.0, 1.0]), np.array([0.0, 0.0]), np.array([[1.0, 0.0]] * 3), -1e-3)


@settings(max_examples=400, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(3, 40), st.floats(-2, 2), st.floats(-2, 2), st.booleans())
def test_a_walk_from_any_start_finds_the_level_walks_plane(seed, k, b0, c0, lattice):
    """``support_plane(start=...)``: the same lowest plane as the walk from level, to rounding,
    from any start; on a lattice of points (the origin often over an edge or a point of the
    upper hull, where several planes are lowest) it gives the level walk's choice."""
    rng = np.random.default_rng(seed)
    if lattice:
        u, v = (rng.integers(-2, 3, k).astype(float) for _ in range(2))
        z = rng.integers(0, 3, k).astype(float) * 0.5
    else:
        u, v, z = rng.uniform(-3, 3, k), rng.uniform(-1.5, 1.5, k), rng.normal(0, 0.3, k)
    cold = support_plane(u, v, z, k, EPS_XY)
    warm = support_plane(u, v, z, k, EPS_XY, start=(b0, c0))
    assert warm[3] == cold[3]
    if cold[3] == 0:
        np.testing.assert_allclose(warm[:3], cold[:3], rtol=0, atol=1e-9)
        assert support_plane_brute_force(u, v, z) == pytest.approx(cold[0], abs=1e-9)


def test_the_walk_turns_past_a_line_through_the_origin_beyond_its_points():
    """Found by the test above: the level walk's first two points, (0, 2) and (0, 1), lie on a
    line through the origin but both on one side of it. Turning about that line cannot lower
    the origin; the walk must turn about (0, 1) alone (it stopped at 1.0, not the lowest 0.833)."""
    u = np.array([0.0, 1, -2, -2, 0, 2, 0, -1, 1])
    v = np.array([-2.0, -2, -1, -2, 2, 2, 1, 2, 1])
    z = np.array([0.0, 0.5, 0, 0.5, 1, 0.5, 1, 1, 0.5])
    a, b, c, status = support_plane(u, v, z, 9, EPS_XY)
    assert status == 0
    assert a == pytest.approx(5 / 6, abs=1e-12) == support_plane_brute_force(u, v, z)
    assert (a + b * u + c * v >= z - 1e-12).all()
