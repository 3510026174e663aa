"""The compiled jet curvature (``curvature.jet_fit``) against its numpy oracle (``jet.nearest_neighbours``
with cKDTree, ``jet.jet_fit_numpy``): the same neighbours, the same H to rounding, any thread count."""

import numpy as np
import pytest

from tankcd_cli.threads import get_num_threads, set_num_threads
from tankcd_cli.terrain.curvature import jet as C
from tankcd_cli.terrain.curvature import jet_fit as J
from tankcd_cli.terrain.curvature import mean as M
from tankcd_cli.terrain import synthetic as S

UTM = (512_345.0, 4_123_456.0, 250.0)
FIELDS = {
    "gaussian_hill": S.gaussian_hill(4.0, 15.0),
    "saddle": S.saddle(0.02, 0.01),
    "sinusoid": S.sinusoid(1.5, 40.0, 60.0),
}


def _normals(V, F):
    return M.vertex_normals(V, F)


def _both(V, normal, which, **kw):
    fast = C.jet_curvature(V, normal, which, fast=True, **kw)
    slow = C.jet_curvature(V, normal, which, fast=False, **kw)
    return fast, slow


def _agree(fast, slow):
    scale = max(np.abs(slow).max(), 1e-300)
    np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-11 * scale)


@pytest.mark.parametrize("name", sorted(FIELDS))
@pytest.mark.parametrize("seed", [0, 1])
def test_jittered_meshes_agree_with_numpy(name, seed):
    V, F, _ = S.jittered_mesh(FIELDS[name], 12.0, 1.0, seed=seed, offset=UTM)
    normal = _normals(V, F)
    open_verts = M.open_vertices(F, len(V))
    fast, slow = _both(V, normal, ~open_verts.mask)
    _agree(fast, slow)
    # the boundary's one-sided fits: 40 neighbours among the candidates near the boundary
    fast, slow = _both(V, normal, open_verts.mask, k=C.BOUNDARY_NEIGHBOURS, candidates=open_verts.near)
    _agree(fast, slow)
    fast, slow = _both(V, normal, ~open_verts.mask, degree=3)
    _agree(fast, slow)


@pytest.mark.parametrize("mesh", [S.grid_mesh, S.jittered_mesh])
@pytest.mark.parametrize("k,extra_pool", [(20, False), (40, True), (7, False)])
def test_neighbours_are_the_oracles(mesh, k, extra_pool):
    """The regular grid is all ties (equal distances): the index rule decides them."""
    V, F, _ = mesh(FIELDS["gaussian_hill"], 8.0, 1.0, offset=UTM)
    rng = np.random.default_rng(3)
    which = rng.random(len(V)) < 0.5
    candidates = (rng.random(len(V)) < 0.5) if extra_pool else None
    fast = C.nearest_neighbours(V, which, k, candidates, fast=True)
    slow = C.nearest_neighbours(V, which, k, candidates, fast=False)
    np.testing.assert_array_equal(fast, slow)


def test_plane_is_flat_and_sphere_cap_has_its_curvature():
    V, F, _ = S.jittered_mesh(S.plane(0.3, -0.2, 5.0), 10.0, 1.0, offset=UTM)
    fast, slow = _both(V, _normals(V, F), np.ones(len(V), bool))
    assert np.abs(fast).max() < 1e-9 and np.abs(slow).max() < 1e-9

    R = 30.0
    V, F, xy = S.jittered_mesh(S.sphere_cap(R), 10.0, 0.5, seed=4, offset=UTM)
    normal = _normals(V, F)
    which = ~M.open_vertices(F, len(V)).mask
    fast, slow = _both(V, normal, which)
    _agree(fast, slow)
    inner = which & (np.abs(xy).max(axis=1) < 8.0)
    np.testing.assert_allclose(fast[inner], 1.0 / R, rtol=1e-3)


@pytest.mark.parametrize("tilt", [np.pi / 2, np.pi / 2 - 1e-9, 1.2])
def test_near_vertical_patches(tilt):
    """A wall: the fitted normal is horizontal and takes its side from the hint."""
    V, F, _ = S.jittered_mesh(FIELDS["gaussian_hill"], 6.0, 1.0, seed=5)
    c, s = np.cos(tilt), np.sin(tilt)
    V = V @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T + np.array(UTM)
    normal = _normals(V, F)
    fast, slow = _both(V, normal, np.ones(len(V), bool))
    _agree(fast, slow)


def _degenerate_cases():
    rng = np.random.default_rng(6)
    t = np.linspace(0.0, 10.0, 30)
    line = np.column_stack([t, 2 * t, 0.5 * t]) + np.array(UTM)
    V, _, _ = S.jittered_mesh(FIELDS["saddle"], 4.0, 1.0, offset=UTM)
    dup = np.vstack([V, V[:20], V[:5]])  # duplicated points: ties at distance zero
    same = np.tile(np.array(UTM), (25, 1))  # every point the same
    few = np.array(UTM) + rng.normal(0, 1, (6, 3))  # fewer points than neighbours
    plane_line = np.vstack([line, line[0] + np.array([0.0, 0.0, 1.0])])  # a line and one point off it
    return {"collinear": line, "duplicates": dup, "identical": same, "few": few, "line_and_point": plane_line}


@pytest.mark.parametrize("name", sorted(_degenerate_cases()))
def test_degenerate_neighbourhoods_are_finite(name):
    V = _degenerate_cases()[name]
    normal = np.tile([0.0, 0.0, 1.0], (len(V), 1))
    which = np.ones(len(V), bool)
    fast = C.jet_curvature(V, normal, which, fast=True)
    assert np.isfinite(fast).all()
    with np.errstate(all="ignore"):
        slow = C.jet_curvature(V, normal, which, fast=False)
    ok = np.isfinite(slow)
    # with duplicates, or 5 neighbours, the quartic has fewer distinct points than coefficients:
    # the 1e-10 ridge decides it and both solves carry its condition (about 1e11) times the rounding
    rtol = 1e-4 if name in ("duplicates", "few") else 1e-9
    scale = max(np.abs(slow[ok]).max(initial=0.0), 1.0)
    np.testing.assert_allclose(fast[ok], slow[ok], rtol=rtol, atol=1e-9 * scale)
    np.testing.assert_array_equal(C.nearest_neighbours(V, which, fast=True),
                                  C.nearest_neighbours(V, which, fast=False))


def test_fit_is_the_oracles_fit():
    """jet_fit alone, on the oracle's neighbours, UTM offsets and both degrees."""
    V, F, _ = S.jittered_mesh(FIELDS["sinusoid"], 10.0, 1.0, seed=7, offset=UTM)
    normal = _normals(V, F)
    sel = np.arange(len(V))
    nbr = C.nearest_neighbours(V, np.ones(len(V), bool), 20, fast=False)
    for degree in (3, 4):
        _agree(J.jet_fit(V, normal, sel, nbr, degree), C.jet_fit_numpy(V, normal, sel, nbr, degree))


def test_thread_count_does_not_change_the_bits():
    V, F, _ = S.jittered_mesh(FIELDS["gaussian_hill"], 20.0, 1.0, seed=8, offset=UTM)
    normal = _normals(V, F)
    which = np.ones(len(V), bool)
    old = get_num_threads()
    try:
        out = []
        for t in (1, 2, 3):
            set_num_threads(t)
            out.append((C.jet_curvature(V, normal, which), C.nearest_neighbours(V, which)))
    finally:
        set_num_threads(old)
    for H, nbr in out[1:]:
        np.testing.assert_array_equal(H, out[0][0])
        np.testing.assert_array_equal(nbr, out[0][1])


def test_mean_curvature_jet_uses_the_compiled_path_and_agrees():
    V, F, _ = S.jittered_mesh(FIELDS["gaussian_hill"], 12.0, 1.0, offset=UTM)
    normal = _normals(V, F)
    H = M.mean_curvature(V, F, "jet")
    open_verts = M.open_vertices(F, len(V))
    expect = C.jet_curvature(V, M.unit_or_up(normal), ~open_verts.mask, fast=False)
    _agree(H[~open_verts.mask], expect[~open_verts.mask])


def test_bad_arguments():
    V = np.zeros((5, 3))
    with pytest.raises(ValueError):
        J.jet_fit(np.zeros((5, 2)), V, [0], [[1, 2]])
    with pytest.raises(IndexError):
        J.jet_fit(V, V, [0], [[1, 7]])
    with pytest.raises(ValueError):
        J.jet_fit(V, V, [0], [[1, 2]], degree=5)
    with pytest.raises(ValueError):
        J.neighbours(V, [0, 1], 4, 6)  # extra > points
    with pytest.raises(ValueError):
        J.neighbours(np.full((5, 3), np.nan), [0], 2, 3)
    assert J.neighbours(V, np.zeros(0, np.int64), 2, 3).shape == (0, 2)
