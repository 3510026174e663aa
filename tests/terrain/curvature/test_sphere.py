"""The paper's sphere estimator: exact where a sphere fits, zero on coplanar points, and the
bias by twist that keeps it from being the default."""

import numpy as np
import pytest

from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.curvature.mean import METHODS, mean_curvature

HALF = 12.0


def interior(xy, spacing, margin=2):
    return np.minimum(HALF - np.abs(xy[:, 0]), HALF - np.abs(xy[:, 1])) > margin * spacing


@pytest.mark.parametrize("field", [S.cylinder_crest(15.0), S.sphere_cap(30.0)], ids=["cylinder", "sphere"])
def test_spheres_and_cylinders_to_second_order(field):
    """Where the four points of every edge lie on the surface's own sphere or cylinder, H = 1/30
    comes out within 0.1 % at 1 m posts, and the error falls about 4 times per halving."""
    errors = []
    for h in (1.0, 0.5, 0.25):
        V, F, xy = S.grid_mesh(field, HALF, h)
        errors.append(np.abs(mean_curvature(V, F, "sphere")[interior(xy, h, 1)] * 30 - 1).max())
    assert errors[0] < 1e-3
    assert errors[1] < errors[0] / 3 and errors[2] < errors[1] / 3


def test_sphere_estimator_is_biased_by_twist():
    """The paper's four-point sphere passes through the two vertices opposite an
    edge, one on each side of it; a twist (f_xy) lifts one and lowers the other,
    and the sphere through them is far too small. Measured, not assumed: why
    ``sphere`` is offered for comparison but is not the default."""
    for twist, factor in ((0.0, 1.0), (0.01, 2.0), (0.03, 4.0)):
        field = S.HeightField("twisted", lambda x, y: 0.01 * x * x + twist * x * y,
                              lambda x, y: (0.02 * x + twist * y, twist * x),
                              lambda x, y: (0.02 + 0 * x, twist + 0 * x, 0 * x))
        V, F, xy = S.grid_mesh(field, 4.0, 1.0)
        centre = int(np.argmin(np.hypot(xy[:, 0], xy[:, 1])))
        H = {m: mean_curvature(V, F, m)[centre] for m in METHODS}
        assert H["cotan"] == pytest.approx(-0.01, rel=1e-3)
        assert H["jet"] == pytest.approx(-0.01, rel=1e-6)
        assert H["sphere"] == pytest.approx(-0.01 * factor, rel=0.01)


def test_sphere_method_coplanar_neighbours_give_zero_not_inf():
    """Four coplanar points: a singular 3x3 system means zero normal curvature."""
    V, F, _ = S.grid_mesh(S.plane(0.1, 0.2), 3.0, 1.0)
    V[:, 2] += 1e-13 * np.sin(V[:, 0] * 7)  # round-off-level noise on a plane
    H = mean_curvature(V, F, "sphere")
    assert np.isfinite(H).all() and np.abs(H).max() < 1e-9
