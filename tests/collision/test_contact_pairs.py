"""The triangle pairs of a first contact: the compiled kernel against its numpy twin."""

import numpy as np

from tankcd_cli.collision.contact_pairs import near_triangle_pairs, near_triangle_pairs_numpy
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
        got = near_triangle_pairs(np.ascontiguousarray(A), np.ascontiguousarray(B), reach)
        want = near_triangle_pairs_numpy(A, B, reach)
        for g, w in zip(got, want):
            assert g.dtype == np.int64 and np.array_equal(g, w)
    z = np.zeros((0, 4, 3, 3))
    assert all(len(v) == 0 for v in near_triangle_pairs(z, z, reach))
