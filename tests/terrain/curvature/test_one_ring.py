"""The compiled curvature passes (``curvature.one_ring``): their arithmetic written out as plain
Python (the same IEEE operations in the same order), the inputs they take, any thread count."""

import numpy as np
import pytest

from tankcd_cli.threads import get_num_threads, set_num_threads
from tankcd_cli.terrain.curvature import one_ring as k


def cotan_accumulate_python(V, F):
    """The face pass written out as plain Python, line for line (the same IEEE operations)."""
    n = V.shape[0]
    K, N, A = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
    e, cot, len2 = np.empty((3, 3)), np.empty(3), np.empty(3)
    for f in range(F.shape[0]):
        i, j, kk = F[f]
        idx = (i, j, kk)
        for c in range(3):
            e[0, c] = V[kk, c] - V[j, c]
            e[1, c] = V[i, c] - V[kk, c]
            e[2, c] = V[j, c] - V[i, c]
        nx = -(e[2, 1] * e[1, 2] - e[2, 2] * e[1, 1])
        ny = -(e[2, 2] * e[1, 0] - e[2, 0] * e[1, 2])
        nz = -(e[2, 0] * e[1, 1] - e[2, 1] * e[1, 0])
        if nz < 0:
            nx, ny, nz = -nx, -ny, -nz
        dbl = np.sqrt(nx * nx + ny * ny + nz * nz)
        for a in range(3):
            b, d = (a + 1) % 3, (a + 2) % 3
            len2[a] = e[a, 0] * e[a, 0] + e[a, 1] * e[a, 1] + e[a, 2] * e[a, 2]
            cot[a] = -(e[d, 0] * e[b, 0] + e[d, 1] * e[b, 1] + e[d, 2] * e[b, 2]) / dbl
        for a in range(3):
            p, q = idx[(a + 1) % 3], idx[(a + 2) % 3]
            for c in range(3):
                w = cot[a] * e[a, c]
                K[p, c] += w
                K[q, c] -= w
            N[idx[a]] += (nx, ny, nz)
        obtuse = cot[0] < 0 or cot[1] < 0 or cot[2] < 0
        area = dbl / 2.0
        for a in range(3):
            if obtuse:
                A[idx[a]] += area / 2.0 if cot[a] < 0 else area / 4.0
            else:
                b, d = (a + 1) % 3, (a + 2) % 3
                A[idx[a]] += (len2[d] * cot[d] + len2[b] * cot[b]) / 8.0
    return K, N, A


def _mesh(rows, cols, seed, holes=0.2):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:rows, 0:cols].astype(float)
    z = np.cumsum(rng.normal(0, 0.3, (rows, cols)), axis=1)
    V = np.column_stack([x.ravel() * 1.3 + 512_000.0 + rng.normal(0, 0.2, rows * cols), y.ravel() * 0.9 + 4.1e6,
                         z.ravel()])
    idx = np.arange(rows * cols).reshape(rows, cols)
    sw, se, nw, ne = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    F = np.concatenate([np.column_stack([sw, se, ne]), np.column_stack([sw, ne, nw])])
    F = rng.permutation(F[rng.random(len(F)) > holes])
    return V, F


def test_cotan_accumulate_is_the_plain_arithmetic():
    V, F = _mesh(9, 11, 3)
    for got, want in zip(k.cotan_accumulate(V, F.astype(np.int32)), cotan_accumulate_python(V, F)):
        np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
    # float32 vertices: their edge differences taken in float32
    V32 = V.astype(np.float32) - np.float32(512_000.0)
    for got, want in zip(k.cotan_accumulate(V32, F), cotan_accumulate_python(V32, F)):
        np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))


def test_cotan_accumulate_edge_cases():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]])
    with pytest.raises(ZeroDivisionError):  # a zero-area face has no cotangents
        k.cotan_accumulate(V, np.array([[0, 1, 3], [0, 1, 2]]))
    wrapped = k.cotan_accumulate(V, np.array([[0, 1, -1]]))  # a negative index counts from the end
    for a, b in zip(wrapped, k.cotan_accumulate(V, np.array([[0, 1, 3]]))):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(IndexError):
        k.cotan_accumulate(V, np.array([[0, 1, 4]]))
    K, N, A = k.cotan_accumulate(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    assert K.shape == (0, 3) and N.shape == (0, 3) and A.shape == (0,)


def test_open_vertex_flags_any_thread_count_and_the_pieces_agree():
    V, F = _mesh(60, 70, 5, holes=0.1)
    F = np.vstack([F, [[F[0, 0], F[0, 1], len(V)]], [[F[3, 0], F[3, 1], len(V)]]])  # fins: non-manifold
    n = len(V) + 3  # and isolated vertices
    threads = get_num_threads()
    try:
        set_num_threads(1)
        one = k.open_vertex_flags(F, n, 2)
        set_num_threads(2)
        two = k.open_vertex_flags(F, n, 2)
    finally:
        set_num_threads(threads)
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a, b)
    start, face = k.vertex_face_csr(F, n)
    assert start[-1] == face.size == 3 * len(F)
    boundary, nonmanifold = k.boundary_flags(F, n, start, face)
    np.testing.assert_array_equal(boundary, one[0])
    np.testing.assert_array_equal(nonmanifold, one[1])
    assert boundary[-2:].all() and nonmanifold.any()
    near = k.grow_rings(F, start, face, boundary | nonmanifold, 2)
    np.testing.assert_array_equal(near, one[2])
    assert near.dtype == bool and (near >= (boundary | nonmanifold)).all()
    # the mask comes back in the seed's dtype: the seed with the grown vertices set
    seed = np.zeros(n, np.int64)
    seed[F[10, 0]] = 3
    grown = k.grow_rings(F, start, face, seed, 1)
    assert grown.dtype == np.int64 and grown[F[10, 0]] == 3 and set(np.unique(grown)) == {0, 1, 3}
    np.testing.assert_array_equal(k.grow_rings(F, start, face, seed, 0), seed)


def test_bad_indices_raise_instead_of_reading_out_of_bounds():
    F = np.array([[0, 1, 2], [1, 2, 5]])
    with pytest.raises(IndexError):
        k.vertex_face_csr(F, 4)
    with pytest.raises(IndexError):
        k.open_vertex_flags(F, 4, 2)
    start, face = k.vertex_face_csr(F, 6)
    with pytest.raises(ValueError):
        k.boundary_flags(F, 7, start, face)
    b, nm, near = k.open_vertex_flags(np.zeros((0, 3), np.int64), 0, 2)
    assert b.shape == nm.shape == near.shape == (0,)
