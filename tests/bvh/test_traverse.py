"""The compiled tree walk: the inputs it takes (any layout, read-only, other dtypes),
any thread count, same answers."""

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from tankcd_cli.threads import get_num_threads, set_num_threads
from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.query import collide
from tankcd_cli.bvh.traverse import ALL, FIRST, brute_force_batch, collide_batch
from tankcd_cli.geometry import kdop
from tankcd_cli.vehicle_mesh import box, cylinder


def test_collide_batch_same_on_one_and_two_threads_and_any_int_width():
    A = cylinder([0, 0, 0], 2, 1.0, 2.0, 10, 3)
    B = box([-2, -0.5, -0.5], [2, 0.5, 0.5], 3)
    ta, tb = build_tree(A, k=18, aabb_levels=2), build_tree(B, k=18)
    R = Rotation.random(200, random_state=1).as_matrix()
    t = np.random.default_rng(1).uniform(-2.5, 2.5, (200, 3))
    threads = get_num_threads()
    try:
        set_num_threads(1)
        one = collide(ta, tb, R, t, all_contacts=True, max_contacts=8)
        set_num_threads(2)
        two = collide(ta, tb, R, t, all_contacts=True, max_contacts=8)
    finally:
        set_num_threads(threads)
    for name in ("found", "pairs", "points", "node_tests", "tri_tests"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    assert one.hit.any() and not one.hit.all()
    d = kdop.directions(18)
    W = np.stack([np.linalg.inv(d[x]) for x in kdop.triples(18)])
    narrow = ("source_index", "left", "right", "start", "count", "depth")
    a = dataclasses.replace(ta, **{f: getattr(ta, f).astype(np.int32) for f in narrow})
    b = dataclasses.replace(tb, **{f: getattr(tb, f).astype(np.int32) for f in narrow})
    res = collide_batch(R, t, d, W, a, b, ALL, 8)
    np.testing.assert_array_equal(res[0], one.found)
    np.testing.assert_array_equal(res[1], one.pairs)
    assert res[1].dtype == np.int64 and res[2].shape == (200, 8, 3)
    np.testing.assert_array_equal(brute_force_batch(R, t, A, B, FIRST) > 0, one.hit)


def test_no_poses():
    ta = tb = build_tree(box([0, 0, 0], [1, 1, 1]))
    res = collide(ta, tb, np.zeros((0, 3, 3)), np.zeros((0, 3)))
    assert res.found.shape == (0,) and res.pairs.shape == (0, 16, 2)
    assert brute_force_batch(np.zeros((0, 3, 3)), np.zeros((0, 3)), ta.triangles, tb.triangles, ALL).shape == (0,)
