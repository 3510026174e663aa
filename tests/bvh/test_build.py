"""Tree construction: every triangle in exactly one leaf, every node's volume containing its children's
and its triangles', tighter volume types testing fewer pairs."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.query import collide
from tankcd_cli.geometry import kdop
from tankcd_cli.vehicle import vehicle_preset
from tankcd_cli.vehicle_mesh import box, vehicle_mesh


def test_tighter_volumes_test_fewer_pairs():
    A, _ = vehicle_mesh(vehicle_preset("t72"), 2)
    B = box([-10, -10, 0], [10, 10, 3], 6)
    rng = np.random.default_rng(1)
    R = Rotation.random(300, random_state=1).as_matrix()
    t = rng.uniform(-8, 8, (300, 3)) + [0, 0, 3]
    tests = {}
    for k, levels in ((6, 0), (26, 0), (26, 2)):
        tests[k, levels] = collide(build_tree(A, k=k, aabb_levels=levels), build_tree(B, k=k, aabb_levels=levels),
                                   R, t, all_contacts=True).tri_tests.sum()
    assert tests[26, 0] < tests[6, 0]


def test_build_is_sound_on_many_triangles():
    rng = np.random.default_rng(2)
    c = rng.uniform(0, 100, (20000, 3))
    tri = c[:, None, :] + rng.normal(0, 0.3, (20000, 3, 3))
    tree = build_tree(tri, k=14, leaf_size=4, split="sah")
    leaf = tree.left < 0
    assert tree.count[leaf].sum() == len(tri) and tree.count[leaf].max() <= 4
    assert sorted(tree.source_index.tolist()) == list(range(len(tri)))
    lo, hi = kdop.fit(tree.triangles, 14)
    owner = np.repeat(np.flatnonzero(leaf), tree.count[leaf])
    first = np.concatenate([np.arange(s, s + n) for s, n in zip(tree.start[leaf], tree.count[leaf])])
    assert (tree.lo[owner] <= lo[first]).all() and (tree.hi[owner] >= hi[first]).all()
    inner = ~leaf
    for child in (tree.left[inner], tree.right[inner]):
        assert (tree.lo[inner] <= tree.lo[child]).all() and (tree.hi[inner] >= tree.hi[child]).all()
    d = tree.describe()
    assert d["aabb_nodes"] == 3 and json.dumps(d)





@pytest.mark.parametrize("split", ["median", "sah"])
@pytest.mark.parametrize("leaf_size", [1, 3, 8])
def test_leaves_partition_the_input_and_depths_count_from_the_root(split, leaf_size):
    rng = np.random.default_rng(leaf_size)
    tri = rng.uniform(0, 10, (257, 1, 3)) + rng.normal(0, 0.2, (257, 3, 3))
    tree = build_tree(tri, k=18, leaf_size=leaf_size, split=split, aabb_levels=1)
    np.testing.assert_array_equal(tree.triangles, tri[tree.source_index])  # leaf order, input index kept
    leaf = tree.left < 0
    assert (tree.count[~leaf] == 0).all() and (tree.count[leaf] >= 1).all() and tree.count[leaf].max() <= leaf_size
    ranges = sorted(zip(tree.start[leaf].tolist(), tree.count[leaf].tolist()))
    assert ranges[0][0] == 0 and all(a + n == b for (a, n), (b, _) in zip(ranges, ranges[1:]))
    assert sum(n for _, n in ranges) == len(tri)
    inner = np.flatnonzero(~leaf)
    assert tree.depth[0] == 0 and (tree.left[inner] > inner).all() and (tree.right[inner] > inner).all()
    np.testing.assert_array_equal(tree.depth[tree.left[inner]], tree.depth[inner] + 1)
    d = tree.describe()
    assert d["nodes"] == tree.nodes == 2 * d["leaves"] - 1 and d["leaf_triangles_max"] <= leaf_size
    assert d["aabb_nodes"] == 1 and sum(d["nodes_per_level"]) == d["nodes"]


def test_one_triangle_is_a_leaf_and_bad_arguments_are_refused():
    T = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], float)
    tree = build_tree(T, k=6)
    assert tree.nodes == 1 and tree.count.tolist() == [1] and tree.left.tolist() == [-1]
    np.testing.assert_array_equal(tree.lo[0], [0, 0, 0])
    np.testing.assert_array_equal(tree.hi[0], [1, 1, 0])
    with pytest.raises(ValueError, match="no triangles"):
        build_tree(np.zeros((0, 3, 3)))
    with pytest.raises(ValueError, match="unknown split rule"):
        build_tree(T, split="middle")
