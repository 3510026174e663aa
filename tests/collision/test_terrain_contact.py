"""The hull's bottom against the terrain: the face's closed form, the exact depth against the dense
sampling oracle on generated terrains (a DEM and an irregular mesh), and contacts equal to depth
above the tolerance."""

import numpy as np
import pytest

from tankcd_cli.collision.terrain_contact import (
    hull_bottom_contacts,
    hull_bottom_depth,
    hull_bottom_face,
    hull_bottom_points,
)
from tankcd_cli.geometry.pose import attitude_from_slopes, rotation_matrix
from tankcd_cli.matching.match import match
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")


@pytest.mark.parametrize("spacing", [0.5, 1.0])
def test_hull_bottom_depth_is_the_supremum_of_dense_sampling(spacing):
    """Terrain contact under the hull: the exact pass is never below a dense sampling of the
    bottom face, and above it by no more than the ground can rise between samples."""
    from tankcd_cli.collision.terrain_contact import hull_bottom_depth
    from tankcd_cli.collision.terrain_contact import hull_bottom_points

    rng = np.random.default_rng(3)
    n = int(60 / spacing)
    Z = np.cumsum(rng.normal(0, 0.15 * spacing, (n, n)), axis=0) + 0.8 * np.sin(np.arange(n) * spacing / 2.0)[None, :]
    surface = S.surface_of(S.dem_terrain(Z, spacing=spacing))
    m = 400
    x, y, yaw = rng.uniform(8, 52, m), rng.uniform(8, 52, m), rng.uniform(-np.pi, np.pi, m)
    p = match(surface, T72, x, y, yaw, "two_point")  # a coarse matcher: the hull often meets the ground
    exact = hull_bottom_depth(surface, T72, x, y, p.yaw, p.plane, p.roll, p.pitch)
    clip = hull_bottom_depth(surface, T72, x, y, p.yaw, p.plane, p.roll, p.pitch, dem=False)
    np.testing.assert_allclose(exact, clip, atol=1e-9)
    dense = surface.ground_above(p.rotation, p.position, hull_bottom_points(T72, along=121, across=61))
    assert (exact >= dense - 1e-9).all()
    steepest = np.abs(np.diff(Z, axis=0)).max() / spacing + np.abs(np.diff(Z, axis=1)).max() / spacing
    assert (exact - dense).max() <= steepest * 0.06 + 1e-9  # samples are 5.7 cm apart at most
    assert (exact > 0.05).sum() > 10  # the case is not vacuous: the hull does touch


def test_bottom_points_span_the_face_at_ground_clearance():
    pts = hull_bottom_points(T72, along=5, across=3)
    assert pts.shape == (15, 3)
    assert (pts[:, 2] == T72.ground_clearance).all()
    np.testing.assert_allclose(np.unique(pts[:, 0]), np.linspace(-T72.hull_length / 2, T72.hull_length / 2, 5))
    np.testing.assert_allclose(np.unique(pts[:, 1]), np.linspace(-T72.hull_width / 2, T72.hull_width / 2, 3))


def test_bottom_face_is_the_tilted_rectangle_and_its_plane():
    """Each half's corners are the face's corners (x, y, clearance) turned by Ry(pitch) Rx(roll) and
    lifted to the support plane, seen from above; the plane returned passes through every one."""
    rng = np.random.default_rng(1)
    n = 40
    planes = np.column_stack([rng.normal(100, 5, n), rng.uniform(-0.4, 0.4, n), rng.uniform(-0.4, 0.4, n)])
    roll, pitch = attitude_from_slopes(planes[:, 1], planes[:, 2])
    quads, bottom = hull_bottom_face(T72, planes, roll, pitch)
    assert quads.shape == (n, 2, 4, 2) and bottom.shape == (n, 3)
    np.testing.assert_array_equal(bottom[:, 1:], planes[:, 1:])  # parallel to the support plane
    L, W, h = T72.hull_length / 2, T72.hull_width / 2, T72.ground_clearance
    halves = [[(-L, 0), (L, 0), (L, W), (-L, W)], [(-L, -W), (L, -W), (L, 0), (-L, 0)]]
    M = rotation_matrix(roll, pitch, np.zeros(n))
    for half, corners in enumerate(halves):
        for j, (X, Y) in enumerate(corners):
            p = M @ np.array([X, Y, h]) + np.column_stack([np.zeros(n), np.zeros(n), planes[:, 0]])
            np.testing.assert_allclose(quads[:, half, j], p[:, :2], atol=1e-12)
            np.testing.assert_allclose(bottom[:, 0] + bottom[:, 1] * p[:, 0] + bottom[:, 2] * p[:, 1], p[:, 2], atol=1e-9)
    # counter-clockwise seen from above
    q = quads
    area = 0.5 * np.sum(q[..., 0] * np.roll(q[..., 1], -1, axis=-1) - np.roll(q[..., 0], -1, axis=-1) * q[..., 1], axis=-1)
    assert (area > 0).all()


@pytest.mark.parametrize("mesh", ["dem", "jittered"])
def test_on_a_plane_the_ground_lies_the_clearance_below_along_the_normal(mesh):
    """Resting on a tilted plane, the bottom face is parallel to the ground and ground_clearance away
    along the normal: vertically, h sqrt(1 + a^2 + b^2) above it, everywhere."""
    a, b = 0.15, -0.1
    if mesh == "dem":
        xs = np.arange(61) * 1.0
        Z = 50 + a * xs[None, :] + b * xs[:, None]
        surface = S.surface_of(S.dem_terrain(Z))
        x0 = 0.0
    else:
        V, F, _ = S.jittered_mesh(S.plane(a, b, 50.0), 30.0, 1.0, seed=2)
        surface = S.surface_of(S.mesh_terrain(V, F))
        x0 = -30.0
    rng = np.random.default_rng(3)
    m = 200
    x, y, yaw = x0 + rng.uniform(12, 48, m), x0 + rng.uniform(12, 48, m), rng.uniform(-np.pi, np.pi, m)
    p = match(surface, T72, x, y, yaw, "reference")
    depth = hull_bottom_depth(surface, T72, x, y, p.yaw, p.plane, p.roll, p.pitch)
    np.testing.assert_allclose(depth, -T72.ground_clearance * np.sqrt(1 + a * a + b * b), atol=1e-9)
    hit, got = hull_bottom_contacts(surface, T72, x, y, p.yaw, p.plane, p.roll, p.pitch, 0.0)
    assert len(hit) == len(got) == 0


@pytest.mark.parametrize("mesh", ["dem", "jittered"])
def test_mesh_depth_is_the_supremum_of_dense_sampling(mesh):
    """The irregular mesh as the DEM above: never below the dense oracle, and above it by at most
    what the ground can rise between samples."""
    rng = np.random.default_rng(4)
    field = S.sinusoid(0.9, 17.0, 13.0)
    if mesh == "dem":
        V, F, _ = S.grid_mesh(field, 30.0, 1.0)
        surface = S.surface_of(S.dem_terrain(V[:, 2].reshape(61, 61), origin=(-30.0, -30.0)))
    else:
        V, F, _ = S.jittered_mesh(field, 30.0, 1.0, seed=5)
        surface = S.surface_of(S.mesh_terrain(V, F))
    m = 300
    x, y, yaw = rng.uniform(-22, 22, m), rng.uniform(-22, 22, m), rng.uniform(-np.pi, np.pi, m)
    p = match(surface, T72, x, y, yaw, "two_point")
    ok = np.flatnonzero(p.status != 2)
    exact = hull_bottom_depth(surface, T72, x[ok], y[ok], p.yaw[ok], p.plane[ok], p.roll[ok], p.pitch[ok])
    dense = surface.ground_above(p.rotation[ok], p.position[ok], hull_bottom_points(T72, along=121, across=61))
    assert (exact >= dense - 1e-9).all()
    # the ground rises between samples at most by the steepest face's |dz/dx| + |dz/dy| times their
    # spacing, over the faces a hull can reach (within 3.9 m of the poses: not the Delaunay slivers of the rim)
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    n = np.cross(e1, e2)
    near = (np.abs(V[F][..., :2]) <= 27.5).all(axis=2).any(axis=1)
    steepest = ((np.abs(n[near, 0]) + np.abs(n[near, 1])) / np.abs(n[near, 2])).max()
    assert (exact - dense).max() <= steepest * 0.06 + 1e-9
    assert (exact > 0.05).sum() > 10


@pytest.mark.parametrize("mesh", ["dem", "jittered"])
@pytest.mark.parametrize("tolerance", [0.0, 0.01, 0.2])
def test_contacts_are_the_poses_whose_depth_exceeds_the_tolerance(mesh, tolerance):
    rng = np.random.default_rng(6)
    field = S.sinusoid(0.6, 23.0, 11.0)
    if mesh == "dem":
        V, _, _ = S.grid_mesh(field, 25.0, 1.0)
        surface = S.surface_of(S.dem_terrain(V[:, 2].reshape(51, 51), origin=(-25.0, -25.0)))
    else:
        V, F, _ = S.jittered_mesh(field, 25.0, 1.0, seed=7)
        surface = S.surface_of(S.mesh_terrain(V, F))
    m = 400
    x, y, yaw = rng.uniform(-30, 30, m), rng.uniform(-30, 30, m), rng.uniform(-np.pi, np.pi, m)  # some off the terrain
    p = match(surface, T72, x, y, yaw, "four_point", measure=False)
    plane = p.plane.copy()
    plane[:, 0] -= rng.uniform(0.0, 0.7, m)  # the hull pushed down into the ground by various amounts
    on = np.flatnonzero(np.isfinite(plane).all(axis=1))
    far = np.append(x[on], x[on[0]] + 1000.0)  # the first pose again, far off the terrain: no ground under it
    on = np.append(on, on[0])
    args = (surface, T72, far, y[on], p.yaw[on], plane[on], p.roll[on], p.pitch[on])
    depth = hull_bottom_depth(*args)
    hit, got = hull_bottom_contacts(*args, tolerance)
    assert hit.dtype == np.int64
    np.testing.assert_array_equal(hit, np.flatnonzero(depth > tolerance))
    np.testing.assert_array_equal(got, depth[hit])
    assert 0 < len(hit) < len(on)
    assert depth[-1] == -np.inf and len(on) - 1 not in hit and np.isfinite(depth[:-1]).all()


def test_no_poses():
    surface = S.surface_of(S.dem_terrain(np.zeros((20, 20))))
    empty = np.zeros(0)
    assert hull_bottom_depth(surface, T72, empty, empty, empty, np.zeros((0, 3)), empty, empty).shape == (0,)
    hit, depth = hull_bottom_contacts(surface, T72, empty, empty, empty, np.zeros((0, 3)), empty, empty, 0.01)
    assert hit.shape == depth.shape == (0,) and hit.dtype == np.int64
