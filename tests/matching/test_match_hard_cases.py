"""Matching where the ground is hardest to read: exact vertices and edges, coplanar triangles,
heading wrap-around, crests at every heading, far from the origin."""

import numpy as np
import pytest

from tankcd_cli.matching.match import MATCHER_CHOICES, match
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")


@pytest.fixture(scope="module")
def bumpy():
    x = np.arange(0, 40.01, 1.0)
    X, Y = np.meshgrid(x, x)
    Z = 0.5 * np.sin(X / 3.0) * np.cos(Y / 4.0) + 0.02 * X
    return S.surface_of(S.dem_terrain(Z, origin=(500_000.0, 4_500_000.0)))


def _finite(p):
    return np.isfinite(p.position).all() and np.isfinite(p.quaternion).all()


@pytest.mark.parametrize("matcher", MATCHER_CHOICES)
def test_on_vertices_and_edges_is_continuous(bumpy, matcher):
    """A footprint centre exactly on a post, on a cell edge or on the cell diagonal gives the
    same pose as one a nanometre away (no seam in point location). Two-point's roll is the
    exception by design: it is the ground's slope across the track under the centre (the
    paper's TPTMA), and a piecewise-linear ground has no single slope at a post or an edge."""
    base = np.array([[20.0, 20.0], [20.5, 20.0], [20.0, 20.5], [20.5, 20.5], [20.25, 20.25]]) + [500_000, 4_500_000]
    yaw = np.array([0.0, np.pi / 2, np.pi / 4, -3 * np.pi / 4, 0.3])
    p = match(bumpy, T72, base[:, 0], base[:, 1], yaw, matcher)
    q = match(bumpy, T72, base[:, 0] + 1e-9, base[:, 1] - 1e-9, yaw, matcher)
    assert _finite(p) and _finite(q)
    np.testing.assert_allclose(p.position, q.position, atol=1e-6)
    if matcher != "two_point":
        np.testing.assert_allclose(p.quaternion, q.quaternion, atol=1e-6)
    else:
        np.testing.assert_allclose(p.pitch, q.pitch, atol=1e-6)


@pytest.mark.parametrize("matcher", MATCHER_CHOICES)
def test_heading_plus_and_minus_180_is_one_pose(bumpy, matcher):
    x, y = np.full(3, 500_017.3), np.full(3, 4_500_021.1)
    p = match(bumpy, T72, x, y, np.array([np.pi, -np.pi, 3 * np.pi]), matcher)
    np.testing.assert_allclose(p.position, p.position[[0, 0, 0]], atol=1e-9)
    np.testing.assert_allclose(np.abs(p.quaternion), np.abs(p.quaternion[[0, 0, 0]]), atol=1e-12)


@pytest.mark.parametrize("matcher", MATCHER_CHOICES)
def test_footprint_on_four_coplanar_triangles_is_the_plane(matcher):
    # a tilted plane made of only four big triangles (two cells): every matcher is exact on it
    a, b, c = 0.04, -0.07, 120.0
    X, Y = np.meshgrid([0.0, 30.0, 60.0], [0.0, 30.0])
    surface = S.surface_of(S.dem_terrain(a * X + b * Y + c, spacing=30.0))
    px, py, yaw = np.array([30.0, 29.0]), np.array([15.0, 14.0]), np.array([0.0, 2.0])
    p = match(surface, T72, px, py, yaw, matcher)
    np.testing.assert_allclose(p.position[:, 2], a * px + b * py + c, atol=1e-9)
    up = p.rotation[:, :, 2]
    np.testing.assert_allclose(up, np.tile([-a, -b, 1.0] / np.linalg.norm([-a, -b, 1.0]), (2, 1)), atol=1e-9)
    assert np.nanmax(p.penetration) < 1e-9


@pytest.mark.parametrize("heading", np.arange(-180, 181, 22.5))
def test_knife_edge_crest_at_every_heading(heading):
    x = np.arange(-20, 20.01, 0.5)
    X, Y = np.meshgrid(x, x)
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    Z = 5 - 0.4 * np.abs(c * X + s * Y)  # a sharp ridge along a diagonal of no grid line
    surface = S.surface_of(S.dem_terrain(Z, origin=(-20.0, -20.0), spacing=0.5))
    h = np.radians(heading)
    d = np.linspace(-5, 5, 41)
    px, py = d * np.cos(h), d * np.sin(h)
    for m in MATCHER_CHOICES:
        p = match(surface, T72, px, py, np.full_like(d, h), m)
        assert _finite(p), m
    ref = match(surface, T72, px, py, np.full_like(d, h), "reference")
    assert np.nanmax(ref.penetration) < 1e-9
    assert (ref.position[:, 2] <= 5 + 1e-9).all()  # the hull never floats above the crest's top


def test_points_off_the_terrain_are_marked_not_crashed(bumpy):
    x = np.array([499_000.0, 500_000.0, 500_020.0, np.nextafter(500_040.0, 0)])
    y = np.full(4, 4_500_020.0)
    for m in MATCHER_CHOICES:
        p = match(bumpy, T72, x, y, np.zeros(4), m)
        assert p.status[0] == 2 and p.status[1] >= 1 and p.status[2] == 0 and p.status[3] >= 1, m
        assert np.isnan(p.position[0, 2]) and np.isfinite(p.position[2]).all()
