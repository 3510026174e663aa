"""The triangle pairs of a first contact and their feature pairs: the compiled kernels against their
numpy twins, and the features' least distance against dense sampling of the two triangles."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.collision.contact_pairs import (near_triangle_pairs, near_triangle_pairs_numpy, plane_separated,
                                                triangle_pair_features, triangle_pair_features_numpy)
from tankcd_cli.geometry.triangles import tri_distance, tri_tri_brute
from tankcd_cli.vehicle import vehicle_preset
from tankcd_cli.vehicle_mesh import vehicle_mesh

T72 = vehicle_preset("t72")


def test_the_compiled_pair_search_of_a_contact_gives_its_numpy_twins_pairs_in_its_order():
    """Random placements of two vehicle meshes near each other, some touching, some far, some with
    boxes exactly ``reach`` apart (the comparisons' edge), and no contacts at all: the kernel's
    (owner, ia, ib) equal the numpy twin's, element for element."""
    rng = np.random.default_rng(11)
    tris, _ = vehicle_mesh(T72, 2)
    reach = 3e-3
    for case in range(6):
        k = int(rng.integers(1, 6))
        A = np.repeat(tris[None], k, axis=0).copy()
        yaw = rng.uniform(-np.pi, np.pi, k)
        c, s = np.cos(yaw), np.sin(yaw)
        R = np.zeros((k, 3, 3))
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1
        gap = rng.choice([0.0, 0.5, 3.0, 50.0], k)
        B = np.matmul(tris[None], np.transpose(R, (0, 2, 1))[:, None]) + np.column_stack(
            [3.46 + gap + rng.uniform(-2, 2, k), rng.uniform(-4, 4, k), np.zeros(k)])[:, None, None, :]
        if case == 5:  # a box edge exactly at reach: b's lowest x equal to a's highest x plus reach
            B = A + np.array([A[..., 0].max() - A[..., 0].min() + reach, 0, 0])
        for planes in (False, True):
            got = near_triangle_pairs(np.ascontiguousarray(A), np.ascontiguousarray(B), reach, planes=planes)
            want = near_triangle_pairs_numpy(A, B, reach, planes=planes)
            for g, w in zip(got, want):
                assert g.dtype == np.int64 and np.array_equal(g, w)
    z = np.zeros((0, 4, 3, 3))
    assert all(len(v) == 0 for v in near_triangle_pairs(z, z, reach))


def test_a_pair_apart_by_a_plane_is_farther_than_reach_and_every_closer_pair_is_kept():
    """The plane test only drops pairs the brute-force distance puts beyond ``reach``: random triangle
    pairs (the hard ones among them) at random offsets, and the ones it keeps include every pair within
    ``reach``. With it on, the kernel keeps exactly the box-near pairs the twin's plane test keeps."""
    rng = np.random.default_rng(5)
    P, Q = _hard_pairs(rng, 3000)
    Q = Q + rng.normal(0, 0.01, (len(Q), 1, 3))
    d = np.array([tri_distance(p, q)[0] for p, q in zip(P, Q)])
    for reach in (3e-3, 0.02, 0.5):
        apart = plane_separated(P, Q, reach)
        assert apart.any() and (d <= reach).any()
        assert (d[apart] > reach - 1e-9).all()
    k = 40
    A, B = P[None, :k], Q[None, :k]
    for planes in (False, True):
        got = near_triangle_pairs(np.ascontiguousarray(A), np.ascontiguousarray(B), 0.02, planes=planes)
        want = near_triangle_pairs_numpy(A, B, 0.02, planes=planes)
        assert all(np.array_equal(g, w) for g, w in zip(got, want))


def _hard_pairs(rng, n):
    """Random triangle pairs with the hard ones mixed in: degenerate (a repeated vertex, a point, a
    micrometre sliver), parallel and coplanar edges, shared vertices, touching, UTM-sized offsets."""
    P = rng.normal(size=(n, 3, 3))
    Q = rng.normal(size=(n, 3, 3)) + rng.normal(scale=2, size=(n, 1, 3))
    q = n // 8
    P[:q, 2] = P[:q, 1]  # a segment
    Q[q:2 * q] = Q[q:2 * q, :1]  # a point
    P[2 * q:3 * q, 1] = P[2 * q:3 * q, 0] + 1e-9  # a sliver
    Q[3 * q:4 * q] = P[3 * q:4 * q] + np.array([0.0, 0.0, 0.5])  # parallel, edges parallel
    Q[4 * q:5 * q, 0] = P[4 * q:5 * q, 1]  # a shared vertex: touching
    Q[5 * q:6 * q, :, 2] = P[5 * q:6 * q, :1, 2]  # coplanar with P's first vertex's height
    P[5 * q:6 * q, :, 2] = P[5 * q:6 * q, :1, 2]
    off = np.array([500_000.0, 5_400_000.0, 300.0])
    P[6 * q:7 * q] += off
    Q[6 * q:7 * q] += off
    return np.ascontiguousarray(P), np.ascontiguousarray(Q)


def test_the_compiled_feature_pairs_are_their_numpy_twins_bit_for_bit():
    """Every distance and closest point of the kernel equals the numpy twin's, bit for bit (NaN where
    the twin's is NaN), on random and hard pairs: the points a contact reports do not depend on which
    one ran."""
    P, Q = _hard_pairs(np.random.default_rng(5), 4000)
    got, want = triangle_pair_features(P, Q), triangle_pair_features_numpy(P, Q)
    assert [g.shape for g in got] == [(4000, 15), (4000, 15, 3), (4000, 15, 3)]
    for g, w in zip(got, want):
        assert np.array_equal(g, w, equal_nan=True)
    empty = np.zeros((0, 3, 3))
    assert [g.shape for g in triangle_pair_features(empty, empty)] == [(0, 15), (0, 15, 3), (0, 15, 3)]


def _sampled_distance(P, Q, n=40):
    """The least distance between dense barycentric samples of P and of Q (an upper bound of their
    distance, within the samples' spacing of it)."""
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    inside = (u + v) <= 1
    w = np.column_stack([1 - u[inside] - v[inside], u[inside], v[inside]])
    a, b = w @ P, w @ Q
    from scipy.spatial import cKDTree

    return cKDTree(b).query(a)[0].min()


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_property_the_least_feature_distance_is_the_distance_of_triangles_that_do_not_cross(seed):
    """For triangles that do not cross, the least of the 15 is their distance: no sample pair comes
    closer (it is a lower bound of the sampled one) and it is within the samples' spacing of the
    sampled one; each feature's two points lie on their triangles, at the distance it says."""
    rng = np.random.default_rng(seed)
    P, Q = _hard_pairs(rng, 16)
    d, cp, cq = triangle_pair_features(P, Q)
    for j in range(len(P)):
        with np.errstate(invalid="ignore", divide="ignore"):  # the oracle's planes of degenerate ones
            crossing = tri_tri_brute(P[j], Q[j])
        if crossing:
            continue
        scale = max(np.ptp(P[j], axis=0).max(), np.ptp(Q[j], axis=0).max())
        sampled = _sampled_distance(P[j] - P[j, 0], Q[j] - P[j, 0])  # about the origin: no UTM roundings
        least = np.nanmin(d[j])
        assert least <= sampled + 1e-9 * (1 + np.abs(P[j]).max())
        assert sampled - least <= scale / 39 * 1.5 + 1e-9 * (1 + np.abs(P[j]).max())
        ok = np.isfinite(d[j])
        np.testing.assert_allclose(np.linalg.norm(cp[j] - cq[j], axis=1)[ok], d[j][ok], atol=1e-9)
