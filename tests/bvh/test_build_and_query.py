"""Trees against brute force: every volume type, layout and split rule, the same contacts."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.query import collide, collide_brute_force
from tankcd_cli.bvh.store import read_tree, write_tree
from tankcd_cli.geometry import kdop
from tankcd_cli.vehicle import vehicle_preset
from tankcd_cli.vehicle_mesh import box, cylinder, vehicle_mesh


def sphere_like(n_seg=10, radius=1.0):
    return cylinder([0, 0, 0], 2, radius, 2 * radius, n_seg, 3)


@pytest.mark.parametrize("k", kdop.KS)
@pytest.mark.parametrize("levels", [0, 2, 99])
@pytest.mark.parametrize("split", ["median", "sah"])
def test_trees_agree_with_brute_force(k, levels, split):
    A = sphere_like()
    B = box([-2, -0.5, -0.5], [2, 0.5, 0.5], 3)
    rng = np.random.default_rng(k + levels)
    n = 150
    R = Rotation.random(n, random_state=k + levels).as_matrix()
    t = rng.uniform(-2.5, 2.5, (n, 3))
    # touching and coplanar cases: the cylinder's flat cap resting exactly on the box's top face
    R[:10] = np.eye(3)
    t[:10] = np.column_stack([rng.uniform(-1.5, 1.5, 10), rng.uniform(-0.3, 0.3, 10), np.full(10, 1.5)])
    ta = build_tree(A, k=k, aabb_levels=levels, split=split)
    tb = build_tree(B, k=k, aabb_levels=levels, split=split)
    first = collide(ta, tb, R, t)
    every = collide(ta, tb, R, t, all_contacts=True, max_contacts=4000)
    np.testing.assert_array_equal(first.hit, collide_brute_force(A, B, R, t) > 0)
    np.testing.assert_array_equal(every.found, collide_brute_force(A, B, R, t, all_contacts=True))
    assert first.hit[:10].all()  # touching counts as contact


def test_grazing_within_a_nanometre():
    A = box([-1, -1, -1], [1, 1, 1])
    B = box([-1, -1, -1], [1, 1, 1])
    ta, tb = build_tree(A), build_tree(B)
    gaps = np.array([-1e-9, 0.0, 1e-9, 1e-6])
    t = np.column_stack([2.0 + gaps, np.zeros(4), np.zeros(4)])
    R = np.repeat(np.eye(3)[None], 4, axis=0)
    hit = collide(ta, tb, R, t).hit
    assert hit.tolist() == [True, True, hit[2], False]  # within round-off either answer is right; 1 um apart is not


def test_contact_points_lie_on_both_triangles():
    A = sphere_like()
    B = box([-2, -0.5, -0.5], [2, 0.5, 0.5], 2)
    ta, tb = build_tree(A), build_tree(B)
    rng = np.random.default_rng(3)
    R = Rotation.random(50, random_state=3).as_matrix()
    t = rng.uniform(-1.5, 1.5, (50, 3))
    res = collide(ta, tb, R, t, all_contacts=True, max_contacts=50)
    for p in np.flatnonzero(res.found):
        for (ia, ib), point in zip(res.pairs[p], res.points[p]):
            if ia < 0:
                break
            for tri in (A[ia] @ R[p].T + t[p], B[ib]):
                n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
                assert abs((point - tri[0]) @ n / np.linalg.norm(n)) < 1e-9


def test_saved_tree_answers_identically(tmp_path):
    A, parts = vehicle_mesh(vehicle_preset("t72"), 2)
    B = box([-3, -3, 0], [3, 3, 4], 4) + [2.0, 0.0, 0.0]
    ta, tb = build_tree(A, k=26, split="sah"), build_tree(B, k=26)
    write_tree(str(tmp_path / "a.h5"), ta, parts)
    loaded, loaded_parts = read_tree(str(tmp_path / "a.h5"))
    np.testing.assert_array_equal(loaded_parts, parts)
    rng = np.random.default_rng(0)
    R = Rotation.random(200, random_state=0).as_matrix()
    t = rng.uniform(-5, 5, (200, 3))
    x, y = collide(ta, tb, R, t, all_contacts=True), collide(loaded, tb, R, t, all_contacts=True)
    for name in ("found", "pairs", "node_tests", "tri_tests"):
        np.testing.assert_array_equal(getattr(x, name), getattr(y, name))


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


def test_agrees_with_python_fcl_when_installed():
    fcl = pytest.importorskip("fcl")
    A, _ = vehicle_mesh(vehicle_preset("t72"), 1)
    B = np.concatenate([box([x, y, 0], [x + 4, y + 4, 5], 2) for x in (0, 8, 16) for y in (0, 8)])
    rng = np.random.default_rng(7)
    R = Rotation.random(300, random_state=7).as_matrix()
    t = np.column_stack([rng.uniform(-4, 24, 300), rng.uniform(-4, 16, 300), rng.uniform(-1, 6, 300)])
    ours = collide(build_tree(A), build_tree(B), R, t).hit

    def model(tris):
        v = tris.reshape(-1, 3)
        m = fcl.BVHModel()
        m.beginModel(len(v), len(tris))
        m.addSubModel(v, np.arange(len(v)).reshape(-1, 3))
        m.endModel()
        return m
    oa, ob = fcl.CollisionObject(model(A), fcl.Transform()), fcl.CollisionObject(model(B), fcl.Transform())
    theirs = np.zeros(300, dtype=bool)
    for i in range(300):
        oa.setTransform(fcl.Transform(R[i], t[i]))
        theirs[i] = fcl.collide(oa, ob, fcl.CollisionRequest(), fcl.CollisionResult()) > 0
    assert ours.mean() > 0.1
    np.testing.assert_array_equal(ours, theirs)
