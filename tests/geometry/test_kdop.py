"""k-DOPs: the fixed direction sets, fits against brute-force projections, overlaps against slab
intervals, and the moved bound that never misses a moved vertex."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tankcd_cli.geometry import kdop


@pytest.mark.parametrize("k", kdop.KS)
def test_directions_are_unit_distinct_and_the_axes_come_first(k):
    d = kdop.directions(k)
    assert d.shape == (k // 2, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-15)
    np.testing.assert_array_equal(d[:3], np.eye(3))
    cos = np.abs(d @ d.T)[np.triu_indices(len(d), 1)]
    assert (cos < 1 - 1e-9).all()  # no direction twice, nor its opposite: k/2 slabs, k faces


def test_directions_are_the_standard_sets():
    s3, s2 = 1 / np.sqrt(3), 1 / np.sqrt(2)
    corners = {tuple(np.round(r, 12)) for r in kdop.directions(14)[3:]}
    assert corners == {tuple(np.round(np.array(c) * s3, 12)) for c in ((1, 1, 1), (1, -1, -1), (1, 1, -1), (1, -1, 1))}
    edges = kdop.directions(18)[3:]
    assert np.allclose(np.sort(np.abs(edges), axis=1), [0, s2, s2])  # two equal components, one zero
    np.testing.assert_array_equal(kdop.directions(26), np.concatenate([kdop.directions(14), edges]))


@pytest.mark.parametrize("k", [0, 4, 8, 12, 20, 32])
def test_other_ks_are_refused(k):
    with pytest.raises(ValueError, match="k-DOPs come with k in"):
        kdop.directions(k)


@pytest.mark.parametrize("k", kdop.KS)
def test_triples_start_with_the_axes_and_are_independent(k):
    t = kdop.triples(k)
    d = kdop.directions(k)
    assert t.dtype == np.int64 and t.shape[1] == 3 and 1 <= len(t) <= kdop.MAX_TRIPLES
    assert t[0].tolist() == [0, 1, 2]
    assert ((t >= 0) & (t < len(d))).all()
    for triple in t:
        assert len(set(triple.tolist())) == 3 and abs(np.linalg.det(d[triple])) > 0.3
    if k > 6:
        assert len(t) == kdop.MAX_TRIPLES  # a diagonal triple besides the axes


@pytest.mark.parametrize("k", kdop.KS)
def test_triple_inverses_invert_the_triples_and_the_shared_arrays_are_read_only(k):
    d, t, W = kdop.directions(k), kdop.triples(k), kdop.triple_inverses(k)
    assert W.shape == (len(t), 3, 3)
    for triple, w in zip(t, W):
        np.testing.assert_allclose(w @ d[triple], np.eye(3), atol=1e-12)
    # the arrays are shared between callers (one per k): writing one would change every later query
    for shared in (d, t, W):
        with pytest.raises(ValueError):
            shared[0] = 0
    # the first well-conditioned triple of the other directions, in the order of combinations
    first = next(c for c in itertools.combinations(range(3, len(d)), 3) if abs(np.linalg.det(d[list(c)])) > 0.3) \
        if k > 6 else None
    if first is not None:
        assert t[1].tolist() == list(first)


@pytest.mark.parametrize("k", kdop.KS)
def test_fit_is_the_extreme_projections(k):
    rng = np.random.default_rng(k)
    pts = rng.normal(0, 3, (4, 7, 3)) + rng.normal(0, 1e5, (4, 1, 3))  # batched, far from the origin
    lo, hi = kdop.fit(pts, k)
    d = kdop.directions(k)
    assert lo.shape == hi.shape == (4, k // 2)
    for b in range(4):
        for i in range(k // 2):
            proj = [sum(float(p[j]) * float(d[i, j]) for j in range(3)) for p in pts[b]]
            assert lo[b, i] == pytest.approx(min(proj), rel=0, abs=1e-9)
            assert hi[b, i] == pytest.approx(max(proj), rel=0, abs=1e-9)
    np.testing.assert_array_equal(lo[:, :3], pts.min(axis=1))  # the first three slabs: the AABB, exactly
    np.testing.assert_array_equal(hi[:, :3], pts.max(axis=1))


@pytest.mark.parametrize("k", kdop.KS)
def test_overlap_is_every_slab_overlapping_and_touching_counts(k):
    rng = np.random.default_rng(10 + k)
    n = 400
    a = rng.normal(0, 1, (n, 5, 3))
    b = rng.normal(0, 1, (n, 5, 3)) + rng.uniform(-4, 4, (n, 1, 3))
    la, ha = kdop.fit(a, k)
    lb, hb = kdop.fit(b, k)
    got = kdop.overlap(la, ha, lb, hb)
    expect = [all(max(la[p, i], lb[p, i]) <= min(ha[p, i], hb[p, i]) for i in range(k // 2)) for p in range(n)]
    assert got.tolist() == expect and 0 < got.sum() < n
    np.testing.assert_array_equal(got, kdop.overlap(lb, hb, la, ha))  # symmetric
    cube = np.array(list(itertools.product([0.0, 1.0], repeat=3)))
    lo, hi = kdop.fit(cube, k)
    lo2, hi2 = kdop.fit(cube + [1.0, 0, 0], k)  # face to face
    assert kdop.overlap(lo, hi, lo2, hi2)
    lo3, hi3 = kdop.fit(cube + [1.0 + 1e-12, 0, 0], k)
    assert not kdop.overlap(lo, hi, lo3, hi3)
    # broadcast: one against many
    assert kdop.overlap(lo[None], hi[None], np.stack([lo2, lo3]), np.stack([hi2, hi3])).tolist() == [True, False]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from(kdop.KS))
def test_property_moved_kdop_is_conservative(seed, k):
    rng = np.random.default_rng(seed)
    pts = rng.normal(0, 1, (20, 3)) * rng.uniform(0.01, 5, 3)  # thin barrels and flat plates too
    lo, hi = kdop.fit(pts, k)
    R = Rotation.random(random_state=seed).as_matrix()
    t = rng.normal(0, 1e5, 3)
    blo, bhi = kdop.rotated_bound(lo[None], hi[None], k, R, t)
    tlo, thi = kdop.fit(pts @ R.T + t, k)
    assert (blo[0] <= tlo + 1e-7).all() and (bhi[0] >= thi - 1e-7).all()


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from(kdop.KS))
def test_property_moved_bound_contains_every_point_of_the_kdop(seed, k):
    """Not only the points it was fitted to: any point inside the k-DOP (here the vertices of
    the polytope itself, from its slabs' three-plane intersections) stays inside the moved bound."""
    rng = np.random.default_rng(seed)
    pts = rng.normal(0, 1, (12, 3)) * rng.uniform(0.05, 3, 3)
    lo, hi = kdop.fit(pts, k)
    d = kdop.directions(k)
    corners = []
    planes = [(d[i], lo[i]) for i in range(len(d))] + [(d[i], hi[i]) for i in range(len(d))]
    for (n1, c1), (n2, c2), (n3, c3) in itertools.combinations(planes, 3):
        A = np.array([n1, n2, n3])
        if abs(np.linalg.det(A)) < 1e-6:
            continue
        x = np.linalg.solve(A, [c1, c2, c3])
        if (x @ d.T >= lo - 1e-9).all() and (x @ d.T <= hi + 1e-9).all():
            corners.append(x)
    corners = np.array(corners)
    assert len(corners) >= 4
    R = Rotation.random(random_state=seed).as_matrix()
    t = rng.normal(0, 100, 3)
    blo, bhi = kdop.rotated_bound(lo[None], hi[None], k, R, t)
    proj = (corners @ R.T + t) @ d.T
    assert (proj >= blo[0] - 1e-7).all() and (proj <= bhi[0] + 1e-7).all()


def test_moved_aabb_is_the_aabb_of_its_moved_corners():
    """k = 6: the bound is the box of the box's eight moved corners, exactly (c +- |R| r)."""
    rng = np.random.default_rng(4)
    n = 50
    lo = rng.normal(0, 2, (n, 3))
    hi = lo + rng.uniform(0.01, 3, (n, 3))
    R = Rotation.random(random_state=4).as_matrix()
    t = np.array([5e5, 4.5e6, 100.0])
    blo, bhi = kdop.rotated_bound(lo, hi, 6, R, t)
    signs = np.array(list(itertools.product([0, 1], repeat=3)))
    corners = np.where(signs[None], hi[:, None], lo[:, None]) @ R.T + t  # (n, 8, 3)
    np.testing.assert_allclose(blo, corners.min(axis=1), rtol=0, atol=1e-8)
    np.testing.assert_allclose(bhi, corners.max(axis=1), rtol=0, atol=1e-8)
    same_lo, same_hi = kdop.rotated_bound(lo, hi, 6, np.eye(3), np.zeros(3))  # not moved: the box itself
    np.testing.assert_allclose(same_lo, lo, atol=1e-12)
    np.testing.assert_allclose(same_hi, hi, atol=1e-12)


@pytest.mark.parametrize("k", [14, 18, 26])
def test_more_directions_never_loosen_the_axes(k):
    """The axes' triple is always among those tried: the moved k-DOP's axis slabs are never wider
    than those of its own AABB moved, and for a thin barrel turned diagonally they are tighter."""
    rng = np.random.default_rng(k)
    barrel = np.column_stack([rng.uniform(-3, 3, 200), rng.normal(0, 0.05, 200), rng.normal(0, 0.05, 200)])
    barrel = barrel @ Rotation.from_euler("z", 45, degrees=True).as_matrix().T  # along a diagonal of the body
    lo, hi = kdop.fit(barrel, k)
    R = Rotation.from_euler("z", -45, degrees=True).as_matrix()
    blo, bhi = kdop.rotated_bound(lo[None], hi[None], k, R, np.zeros(3))
    alo, ahi = kdop.rotated_bound(lo[None, :3], hi[None, :3], 6, R, np.zeros(3))
    assert (blo[0, :3] >= alo[0] - 1e-12).all() and (bhi[0, :3] <= ahi[0] + 1e-12).all()
    if k == 18:  # its second triple is of edge diagonals, which bound a barrel along (1, 1, 0) closely
        assert (bhi[0, 1] - blo[0, 1]) < 0.5 * (ahi[0, 1] - alo[0, 1])
