"""The cotangent estimator's parts against hand-computed triangles, and its H against closed
forms and libigl's cotangent Laplacian."""

import numpy as np
import pytest

from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.curvature.cotan import cotan_curvature, face_corners, mixed_area
from tankcd_cli.terrain.curvature.mean import mean_curvature
from tankcd_cli.terrain.mesh.topology import edge_topology

HALF = 12.0
SURFACES = {"gaussian_hill": S.gaussian_hill(4.0, 15.0)}


def interior(xy, spacing, margin=2):
    return np.minimum(HALF - np.abs(xy[:, 0]), HALF - np.abs(xy[:, 1])) > margin * spacing


def on_boundary(faces, n):
    return edge_topology(faces, n).boundary_vertex


def test_face_corners_of_a_right_triangle():
    """Corners (0, 0, 0), (2, 0, 0), (0, 1, 0): angles 90 deg, atan(1/2), atan(2); the edges
    opposite each corner; the normal up with length twice the area, whatever the winding."""
    V = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    for F in (np.array([[0, 1, 2]]), np.array([[0, 2, 1]])):
        edge, cot, normal = face_corners(V, F)
        f = F[0]
        np.testing.assert_allclose(edge[0], V[f[[2, 0, 1]]] - V[f[[1, 2, 0]]])
        angle = {0: np.pi / 2, 1: np.arctan(0.5), 2: np.arctan(2.0)}
        np.testing.assert_allclose(cot[0], [1 / np.tan(angle[v]) for v in f], atol=1e-15)
        np.testing.assert_allclose(normal[0], [0.0, 0.0, 2.0])


def test_mixed_area_partitions_the_area():
    """Voronoi shares on an acute triangle (its circumcentre inside), Meyer's half and quarters
    on an obtuse one; on any mesh they sum to the total area."""
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, np.sqrt(3) / 2, 0.0]])
    F = np.array([[0, 1, 2]])
    edge, cot, normal = face_corners(V, F)
    np.testing.assert_allclose(mixed_area(F, edge, cot, np.linalg.norm(normal, axis=1), 3), np.sqrt(3) / 12)
    V = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [2.0, 0.5, 0.0]])  # obtuse at vertex 2
    edge, cot, normal = face_corners(V, F)
    np.testing.assert_allclose(mixed_area(F, edge, cot, np.linalg.norm(normal, axis=1), 3), [0.25, 0.25, 0.5])
    V, F, _ = S.jittered_mesh(S.gaussian_hill(2.0, 5.0), 6.0, 1.0, seed=4)
    edge, cot, normal = face_corners(V, F)
    double = np.linalg.norm(normal, axis=1)
    assert mixed_area(F, edge, cot, double, len(V)).sum() == pytest.approx(double.sum() / 2, rel=1e-12)


def test_cotan_curvature_is_zero_where_the_area_is():
    """A vertex in no face has no area: H 0, not NaN."""
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 1.0]])
    F = np.array([[0, 1, 2]])
    edge, cot, normal = face_corners(V, F)
    area = mixed_area(F, edge, cot, np.linalg.norm(normal, axis=1), 4)
    H = cotan_curvature(F, edge, cot, np.tile([0.0, 0.0, 1.0], (4, 1)), area, 4)
    assert H[3] == 0.0 and np.isfinite(H).all()


def test_sphere_and_cylinder_magnitudes():
    V, F, xy = S.grid_mesh(S.sphere_cap(30.0), HALF, 0.5)
    np.testing.assert_allclose(mean_curvature(V, F, "cotan"), 1 / 30, rtol=2e-3)
    V, F, xy = S.grid_mesh(S.cylinder_crest(15.0), HALF, 0.5)
    np.testing.assert_allclose(mean_curvature(V, F, "cotan")[interior(xy, 0.5, 1)], 1 / 30, rtol=1e-9)


def test_matches_libigl_on_regular_grids():
    igl = pytest.importorskip("igl")
    field = SURFACES["gaussian_hill"]
    V, F, xy = S.grid_mesh(field, HALF, 0.5, offset=(500_000.0, 4_500_000.0, 120.0))
    local = V - V.mean(axis=0)  # libigl on raw UTM numbers would lose digits; we do not
    L = igl.cotmatrix(local, F)
    M = igl.massmatrix(local, F, igl.MASSMATRIX_TYPE_VORONOI)
    HN = -(L @ local) / M.diagonal()[:, None]
    from tankcd_cli.terrain.curvature.mean import vertex_normals

    n = vertex_normals(V, F)
    H_igl = 0.5 * np.einsum("ij,ij->i", HN, n)
    H = mean_curvature(V, F, "cotan")
    b = on_boundary(F, len(V))
    scale = np.abs(H_igl[~b]).max()
    assert np.abs(H - H_igl)[~b].max() <= 1e-9 * scale
