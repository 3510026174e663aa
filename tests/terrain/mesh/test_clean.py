"""Mesh clean-up: duplicates merged, degenerate and repeated faces dropped, counts reported."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.terrain.mesh.clean import clean_mesh


def test_duplicate_vertices_are_merged_and_counted():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0], [1 + 1e-8, 0, 0]], dtype=float)
    F = np.array([[0, 1, 2], [3, 4, 2], [5, 4, 2]])  # 3 and 5 duplicate 1; faces 2 and 3 coincide then
    out = clean_mesh(V, F)
    assert len(out.vertices) == 4
    assert out.counts["merged_vertices"] == 2
    assert out.counts["repeated_faces"] == 1
    assert len(out.faces) == 2
    assert out.old_to_new[3] == out.old_to_new[1] == out.old_to_new[5]


def test_degenerate_faces_dropped_slivers_kept():
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [0.5, 1e-7, 0]], dtype=float)
    F = np.array([[0, 1, 2],   # collinear: zero area
                  [0, 1, 3],   # fine
                  [0, 0, 3],   # repeated index
                  [0, 4, 1]])  # sliver: area 5e-8, kept
    out = clean_mesh(V, F)
    assert out.counts["degenerate_faces"] == 2
    assert len(out.faces) == 2
    assert out.counts["unreferenced_vertices"] == 1  # vertex 2 only sat on the collinear face


def test_utm_offsets_do_not_merge_neighbours():
    base = np.array([500000.0, 4500000.0, 100.0])
    V = base + np.array([[0, 0, 0], [1e-3, 0, 0], [0, 1e-3, 0]])
    out = clean_mesh(V, np.array([[0, 1, 2]]))
    assert len(out.vertices) == 3 and out.counts["merged_vertices"] == 0


@settings(max_examples=40, deadline=None)
@given(st.integers(4, 40), st.integers(0, 2**31 - 1))
def test_property_clean_mesh_is_a_valid_mesh(n, seed):
    rng = np.random.default_rng(seed)
    V = rng.integers(0, 4, (n, 3)).astype(float)  # many duplicates and collinear triples
    F = rng.integers(0, n, (2 * n, 3))
    out = clean_mesh(V, F)
    if len(out.faces):
        assert out.faces.max() < len(out.vertices)
        assert len(np.unique(np.sort(out.faces, axis=1), axis=0)) == len(out.faces)
        p = out.vertices[out.faces]
        assert (np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1) > 0).all()
        assert len(np.unique(out.vertices, axis=0)) == len(out.vertices)
    # every kept input vertex maps onto an identical output vertex
    kept = out.old_to_new >= 0
    np.testing.assert_array_equal(out.vertices[out.old_to_new[kept]], V[kept])


@pytest.mark.parametrize("planted", [0, 1, 7])
def test_the_quick_look_for_duplicates_agrees_with_the_pair_search(monkeypatch, planted):
    """Small meshes first ask the compiled k-d tree whether any vertex has a near duplicate;
    the representatives are the pair search's all the same: with none planted, with one, with
    several (pairs inside the merge distance and pairs just outside it), at UTM offsets."""
    from tankcd_cli.terrain.mesh import clean

    rng = np.random.default_rng(planted)
    v = rng.uniform(0, 500, (3000, 3)) + [500_000.0, 4_500_000.0, 0.0]
    for k in range(planted):
        v[10 * k + 1] = v[10 * k] + rng.normal(0, 1, 3) / np.sqrt(3) * 0.4e-6  # inside 1e-6 m
        v[10 * k + 5] = v[10 * k + 4] + [3e-6, 0.0, 0.0]  # outside
    quick = clean._merge_representatives(v, 1e-6)
    monkeypatch.setattr(clean, "SMALL_MESH_VERTICES", 0)
    searched = clean._merge_representatives(v, 1e-6)
    np.testing.assert_array_equal(quick, searched)
    assert int((quick != np.arange(len(v))).sum()) == planted
