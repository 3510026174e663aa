"""Mean curvature by every method against analytic height fields of known H (an independent
truth): signs, accuracy, convergence, boundaries, invariance, the compiled path against numpy."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.curvature.mean import METHODS, mean_curvature
from tankcd_cli.terrain.mesh.topology import edge_topology

HALF = 12.0  # patches of 24 m x 24 m
SURFACES = {
    "sphere_cap": S.sphere_cap(30.0),         # H = +1/30
    "cylinder_crest": S.cylinder_crest(15.0),  # H = +1/30
    "saddle": S.saddle(0.02, 0.01),           # H about -0.01, mixed signs of principal curvature
    "gaussian_hill": S.gaussian_hill(4.0, 15.0),
    "sinusoid": S.sinusoid(1.5, 40.0, 60.0),
}


def relative_error(H, truth):
    """|H - truth| / max(|truth|, a tenth of the patch's largest |truth|): no blow-up where truth crosses zero."""
    floor = 0.1 * np.abs(truth).max()
    return np.abs(H - truth) / np.maximum(np.abs(truth), floor)


def interior(xy, spacing, margin=2):
    """Vertices at least ``margin`` spacings inside the patch (the one-ring and the fit are two-sided there)."""
    return np.minimum(HALF - np.abs(xy[:, 0]), HALF - np.abs(xy[:, 1])) > margin * spacing


def on_boundary(faces, n):
    return edge_topology(faces, n).boundary_vertex


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mesh", [S.grid_mesh, S.jittered_mesh])
@pytest.mark.parametrize("field", [S.plane(), S.plane(0.3, -0.2, 5.0)], ids=["plane", "tilted"])
def test_planes_have_zero_curvature(method, mesh, field):
    V, F, _ = mesh(field, HALF, 1.0)
    H = mean_curvature(V, F, method)
    assert np.abs(H).max() < 1e-9


@pytest.mark.parametrize("method", ["cotan", "sphere", "jet"])
@pytest.mark.parametrize("name", ["sphere_cap", "cylinder_crest", "saddle", "gaussian_hill", "sinusoid"])
def test_regular_grid_accuracy(method, name):
    field = SURFACES[name]
    V, F, xy = S.grid_mesh(field, HALF, 1.0)
    truth = field.mean_curvature(xy[:, 0], xy[:, 1])
    err = relative_error(mean_curvature(V, F, method), truth)
    inner = interior(xy, 1.0)
    if method == "sphere" and name == "sinusoid":
        pytest.skip("the sphere estimator is biased by twist; see test_sphere_estimator_is_biased_by_twist")
    bound = {"cotan": 0.01, "sphere": 0.06, "jet": 0.02}[method]
    assert np.median(err[inner]) < bound / 4
    assert err[inner].max() < bound


def test_signs_follow_the_contract():
    """Hilltops and ridges positive, bowls and valleys negative."""
    for field, sign in ((S.sphere_cap(30.0), 1), (S.cylinder_crest(15.0), 1)):
        for flip in (1, -1):
            V, F, xy = S.grid_mesh(field, HALF, 1.0)
            V[:, 2] *= flip
            for method in METHODS:
                H = mean_curvature(V, F, method)
                assert np.all(np.sign(H) == sign * flip), (field.name, flip, method)


def test_cotan_does_not_converge_on_jittered_meshes_but_jet_does():
    """The known weakness the jet method exists for, measured rather than assumed."""
    field = SURFACES["sphere_cap"]
    med = {}
    for h in (1.0, 0.5):
        V, F, xy = S.jittered_mesh(field, HALF, h, seed=3)
        truth = field.mean_curvature(xy[:, 0], xy[:, 1])
        inner = interior(xy, h)
        for method in ("cotan", "jet"):
            med[method, h] = np.median(relative_error(mean_curvature(V, F, method), truth)[inner])
    assert med["cotan", 0.5] > 0.5 * med["cotan", 1.0] > 0.005  # stalls near 2 %
    assert med["jet", 0.5] < med["jet", 1.0] / 3  # second order: about 4x per halving


@pytest.mark.parametrize("method,mesh", [("cotan", S.grid_mesh), ("jet", S.grid_mesh), ("jet", S.jittered_mesh)])
@pytest.mark.parametrize("name", ["sphere_cap", "saddle", "gaussian_hill"])
def test_second_order_convergence(method, mesh, name):
    field = SURFACES[name]
    errors = []
    for h in (1.0, 0.5, 0.25):
        V, F, xy = mesh(field, HALF, h) if mesh is S.grid_mesh else mesh(field, HALF, h, seed=5)
        truth = field.mean_curvature(xy[:, 0], xy[:, 1])
        region = np.minimum(HALF - np.abs(xy[:, 0]), HALF - np.abs(xy[:, 1])) > 3.0  # a fixed region
        errors.append(np.median(np.abs(mean_curvature(V, F, method) - truth)[region]))
    errors = np.array(errors)
    exact = errors < 1e-8 * np.abs(truth).max()  # a jet reproduces a quadric to round-off
    rates = np.log2(errors[:-1] / errors[1:])[~exact[1:]]
    assert rates.size == 0 or rates.min() > 1.6, (errors, rates)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mesh", [S.grid_mesh, S.jittered_mesh])
@pytest.mark.parametrize("name", ["sphere_cap", "saddle", "gaussian_hill"])
def test_boundary_vertices(method, mesh, name):
    """Boundary: one-sided fit, at most 5 % median error, finite everywhere."""
    field = SURFACES[name]
    V, F, xy = mesh(field, HALF, 1.0)
    truth = field.mean_curvature(xy[:, 0], xy[:, 1])
    H = mean_curvature(V, F, method)
    b = on_boundary(F, len(V))
    assert np.isfinite(H).all()
    assert np.median(relative_error(H, truth)[b]) < 0.05


@pytest.mark.parametrize("method", METHODS)
def test_invariant_under_utm_translation_and_rotation_about_z(method):
    field = SURFACES["gaussian_hill"]
    V, F, _ = S.jittered_mesh(field, HALF, 1.0, seed=7)
    H = mean_curvature(V, F, method)
    a = np.deg2rad(37.0)
    R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    moved = V @ R.T + np.array([512_345.678, 4_456_789.012, 1_234.5])
    H2 = mean_curvature(moved, F, method)
    scale = np.abs(H).max()
    assert np.abs(H - H2).max() < 1e-6 * scale


def test_slivers_obtuse_and_duplicates_stay_finite():
    rng = np.random.default_rng(11)
    xy = rng.uniform(-5, 5, (300, 2))
    xy = np.vstack([xy, xy[:20] + 1e-7, [[0.0, 0.0], [1.0, 0.0], [2.0, 1e-6]]])  # near-duplicates, a near-collinear trio
    from scipy.spatial import Delaunay

    F = Delaunay(xy).simplices.astype(np.int64)
    V = np.column_stack([xy, 0.05 * xy[:, 0] ** 2])
    from tankcd_cli.terrain.mesh.clean import clean_mesh

    clean = clean_mesh(V, F)
    for method in METHODS:
        H = mean_curvature(clean.vertices, clean.faces, method)
        assert np.isfinite(H).all()


@settings(max_examples=25, deadline=None)
@given(a=st.floats(-0.05, 0.05), b=st.floats(-0.05, 0.05), c=st.floats(-0.05, 0.05),
       tx=st.floats(-1e6, 1e6), ty=st.floats(-1e6, 1e6), angle=st.floats(-np.pi, np.pi))
def test_property_quadratic_patches(a, b, c, tx, ty, angle):
    """Random quadratic height fields anywhere, any heading: every method finite;
    the jet reproduces the exact H at the centre of a symmetric patch."""
    field = S.HeightField("quad", lambda x, y: a * x * x + b * x * y + c * y * y,
                          lambda x, y: (2 * a * x + b * y, b * x + 2 * c * y),
                          lambda x, y: (2 * a + 0 * x, b + 0 * x, 2 * c + 0 * x))
    V, F, xy = S.grid_mesh(field, 4.0, 1.0)
    R = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    V = V @ R.T + np.array([tx, ty, 0.0])
    centre = int(np.argmin(np.hypot(xy[:, 0], xy[:, 1])))
    truth = field.mean_curvature(np.zeros(1), np.zeros(1))[0]
    for method in METHODS:
        H = mean_curvature(V, F, method)
        assert np.isfinite(H).all()
    Hj = mean_curvature(V, F, "jet")
    assert abs(Hj[centre] - truth) < 1e-6 + 1e-6 * abs(truth)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mesh", [S.grid_mesh, S.jittered_mesh])
def test_compiled_kernels_agree_with_numpy(method, mesh):
    """The compiled path against its numpy oracle."""
    V, F, _ = mesh(SURFACES["gaussian_hill"], HALF, 1.0, offset=(500_000.0, 4_500_000.0, 0.0))
    F = F.copy()
    F[::7] = F[::7][:, [0, 2, 1]]  # flipped faces must not matter
    slow = mean_curvature(V, F, method, fast=False)
    fast = mean_curvature(V, F, method, fast=True)
    np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-12)


def test_open_vertices_agree_and_find_nonmanifold_edges():
    from tankcd_cli.terrain.curvature.mean import open_vertices

    V, F, _ = S.jittered_mesh(S.plane(), 5.0, 1.0, seed=2)
    F = np.vstack([F, [[F[0, 0], F[0, 1], len(V)]]])  # a fin on edge (F0[0], F0[1]): non-manifold
    n = len(V) + 1
    slow = open_vertices(F, n, fast=False)
    fast = open_vertices(F, n, fast=True)
    np.testing.assert_array_equal(slow.boundary, fast.boundary)
    np.testing.assert_array_equal(slow.nonmanifold, fast.nonmanifold)
    assert fast.nonmanifold[F[0, 0]] and fast.nonmanifold[F[0, 1]] and fast.nonmanifold.sum() == 2
    assert (fast.near >= fast.mask).all()
