"""The gun barrel against a drum where the geometry is tightest: rim on rim, tip on the rim, at every scale."""

import numpy as np
import pytest

from tankcd_cli.geometry.cylinders import cylinders_intersect, projections_overlap

X, Y, Z = np.eye(3)


def both(c, a, h, r, dc, da, dh, dr):
    args = (np.array([c], float), np.array([a], float), h, r, dc, da, dh, dr)
    return bool(cylinders_intersect(*args)[0]), bool(projections_overlap(*args)[0])


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
@pytest.mark.parametrize("offset", [0.0, 4.5e6])
def test_coaxial_caps_rim_on_rim(scale, offset):
    """Parallel axes, the barrel standing on the drum's end plane, rims meeting at one point."""
    hB, rB, hA, rA = 0.44 * scale, 0.30 * scale, 1.0 * scale, 0.11 * scale
    base = np.full(3, offset)
    tol = 1e-9 * max(scale, offset)
    for gap, expected in ((1e-6 * scale, False), (0.0, True), (-1e-6 * scale, True)):
        centre = base + [rA + rB + gap, hB + hA, 0.0]
        got, projected = both(centre, Y, hA, rA, base, Y, hB, rB)
        assert got is expected or abs(gap) <= tol, (gap, got)
        assert projected or not got  # the projection test never misses


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_barrel_tip_on_the_rim(scale):
    """The barrel pointing down at the drum's rim: the rim of its muzzle touches the drum's rim."""
    hB, rB, hA, rA = 0.44 * scale, 0.30 * scale, 1.5 * scale, 0.11 * scale
    for gap, expected in ((1e-6 * scale, False), (-1e-6 * scale, True)):
        # axis vertical, muzzle cap in the plane z = rB + gap, its rim just reaching the drum's end edge
        centre = np.array([0.0, hB + rA, rB + gap + hA])
        got, projected = both(centre, -Z, hA, rA, np.zeros(3), Y, hB, rB)
        assert got is expected, gap
        assert projected or not got


def test_parallel_and_perpendicular_axes_far_from_the_origin():
    off = np.array([500_000.0, 4_500_000.0, 100.0])
    # side by side (parallel), crossing above (perpendicular), and standing on it (the muzzle's cap
    # on the drum's top line): each just touching, then a micrometre apart
    for axis, touch in ((Y, 0.41), (X, 0.41), (Z, 0.30 + 0.5)):
        got, projected = both(off + [0.0, 0.0, touch - 1e-7], axis, 0.5, 0.11, off, Y, 0.44, 0.30)
        assert got and projected, axis
        got, projected = both(off + [0.0, 0.0, touch + 1e-6], axis, 0.5, 0.11, off, Y, 0.44, 0.30)
        assert not got, axis
