"""Collision queries against brute force: every volume type, layout and split rule, the same contacts;
the pairs and points they report are those of triangles that meet."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.query import collide, collide_brute_force
from tankcd_cli.geometry import kdop
from tankcd_cli.geometry.triangles import tri_tri_brute
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


def test_pairs_are_input_indices_of_triangles_that_meet():
    A = sphere_like()
    B = box([-2, -0.5, -0.5], [2, 0.5, 0.5], 2)
    rng = np.random.default_rng(11)
    perm_a, perm_b = rng.permutation(len(A)), rng.permutation(len(B))  # input order is not tree order
    A, B = A[perm_a], B[perm_b]
    ta, tb = build_tree(A, k=14), build_tree(B, k=14)
    R = Rotation.random(60, random_state=11).as_matrix()
    t = rng.uniform(-1.5, 1.5, (60, 3))
    cap = 6
    res = collide(ta, tb, R, t, all_contacts=True, max_contacts=cap)
    counts = collide_brute_force(A, B, R, t, all_contacts=True)
    np.testing.assert_array_equal(res.found, counts)
    assert res.pairs.shape == (60, cap, 2) and res.points.shape == (60, cap, 3)
    assert (res.found > cap).any() and (res.found == 0).any()
    for p in range(60):
        kept = min(int(res.found[p]), cap)
        assert (res.pairs[p, kept:] == -1).all()
        pairs = [tuple(x) for x in res.pairs[p, :kept].tolist()]
        assert len(set(pairs)) == kept  # no pair twice
        for ia, ib in pairs:
            assert tri_tri_brute(A[ia] @ R[p].T + t[p], B[ib])
    np.testing.assert_array_equal(res.hit, res.found > 0)
    first = collide(ta, tb, R, t)
    np.testing.assert_array_equal(first.hit, res.hit)
    assert (first.found <= 1).all()  # the first contact ends the search
    assert (first.tri_tests <= res.tri_tests).all() and (first.node_tests <= res.node_tests).all()


def test_one_pose_and_lists_are_taken_and_mismatched_trees_refused():
    A = box([0, 0, 0], [1, 1, 1])
    ta, tb = build_tree(A, k=18), build_tree(A, k=18)
    one = collide(ta, tb, np.eye(3).tolist(), [0.5, 0.0, 0.0])
    assert one.found.shape == (1,) and one.hit[0]
    apart = collide(ta, tb, np.eye(3), [1.5, 0.0, 0.0])
    assert not apart.hit[0] and apart.tri_tests[0] == 0  # the roots' volumes do not overlap: no triangle tested
    assert collide_brute_force(A, A, [np.eye(3)] * 2, [[0.5, 0, 0], [1.5, 0, 0]]).tolist() == [1, 0]
    with pytest.raises(ValueError, match="same k-DOP type"):
        collide(build_tree(A, k=6), tb, np.eye(3), [0.0, 0.0, 0.0])
