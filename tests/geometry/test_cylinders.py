"""The compiled GJK: pinned distances to the bit, the inputs it takes, any thread count."""

import numpy as np
import pytest

from tankcd_cli.threads import get_num_threads, set_num_threads
from tankcd_cli.geometry.cylinders import cylinders_distance_batch, cylinders_intersect, gjk_distance, projections_overlap

# (cA, aA, hA, rA, cB, aB, hB, rB, plane normal, the distance pinned to the bit (float.hex), stop_apart off)
PINNED = [
    ([0.206, -0.526, 0.359], [0.8647, 0.4818, -0.1417], 1.294, 0.541, [-0.063, 0.295, -0.313], [0.2773, 0.5527, 0.7859], 0.404, 0.461, (0.0, 0.0, 0.0), '0x1.a9efbb070ee54p-6'),
    ([-0.013, -0.705, -0.49], [-0.1063, 0.9664, -0.2341], 0.141, 0.333, [-0.37, 0.4, -0.177], [0.4759, -0.8397, 0.2614], 0.482, 1.456, (0.0, 0.0, 1.0), '0x1.050e3ac96a85bp-5'),
    ([0.122, 0.535, 1.217], [-0.9781, 0.1973, 0.0657], 1.421, 0.502, [-1.492, 0.031, 0.333], [0.6441, -0.6895, 0.3312], 0.874, 0.304, (1.0, 0.0, 0.0), '0x1.202cff159bce7p-7'),
    ([0.145, 0.214, -0.792], [0.5072, 0.7797, -0.3672], 0.844, 0.16, [-0.014, 0.618, -0.135], [0.6524, 0.2371, -0.7198], 0.388, 0.4, (0.0, 0.0, 0.0), '0x1.31039a045b2b0p-4'),
    ([-0.406, 0.202, 0.275], [-0.0627, 0.4729, 0.8789], 0.459, 0.897, [0.038, 1.568, 0.66], [0.1959, -0.9794, 0.0481], 0.232, 0.398, (0.0, 0.0, 1.0), '0x1.cc9c789abe750p-5'),
    ([-0.084, 0.268, 1.491], [-0.6758, 0.7166, -0.1723], 1.142, 0.357, [0.801, 0.666, -0.244], [0.1203, -0.9577, 0.2615], 1.188, 1.181, (1.0, 0.0, 0.0), '0x1.4d6e6593a92a2p-6'),
    ([-0.026, 0.447, -0.991], [0.4707, -0.6463, -0.6007], 0.612, 0.3, [0.395, -0.293, 0.106], [-0.1572, 0.7605, -0.63], 1.044, 0.193, (0.0, 0.0, 0.0), '0x1.ac832ea7678e3p-5'),
    ([-0.305, 0.151, 0.386], [0.0498, -0.9268, -0.3722], 0.274, 0.147, [-1.118, -0.786, 0.444], [-0.5433, -0.2484, 0.8019], 0.545, 0.763, (0.0, 0.0, 1.0), '0x1.eac1d7d7872d0p-7'),
    ([0.654, -0.88, 1.072], [-0.8817, 0.4225, 0.2099], 1.36, 1.096, [-0.876, 0.404, -0.683], [-0.3499, 0.8296, -0.4351], 1.119, 0.282, (1.0, 0.0, 0.0), '0x1.d31a5ebe31614p-7'),
    ([0.519, -0.492, 0.176], [0.1347, -0.9642, 0.2286], 0.248, 0.892, [-0.331, -0.087, -0.901], [0.1544, 0.3503, 0.9238], 0.534, 0.477, (0.0, 0.0, 0.0), '0x1.042aa064c8096p-4'),
    ([0.404, 0.904, -0.39], [-0.7423, -0.3866, 0.5472], 1.255, 0.232, [-0.224, -0.773, -0.01], [-0.1314, 0.3479, 0.9283], 0.256, 0.921, (0.0, 0.0, 1.0), '0x1.abdb23ae3efedp-5'),
    ([-0.43, -0.946, -0.923], [-0.8345, -0.4712, -0.2856], 0.942, 0.145, [0.395, 0.123, 0.515], [0.872, 0.455, -0.1805], 0.823, 1.137, (1.0, 0.0, 0.0), '0x1.98452159e48aep-5'),
]


@pytest.mark.parametrize("case", PINNED)
def test_distances_keep_their_pinned_bits(case):
    *args, nrm, expected = case
    args = [np.array(a) if isinstance(a, list) else a for a in args]
    assert gjk_distance(*args, *nrm, 1e-9, False).hex() == expected


def _sweep(n, seed=0):
    rng = np.random.default_rng(seed)
    az, el = rng.uniform(-np.pi, np.pi, n), rng.uniform(-0.3, 0.5, n)
    axes = np.column_stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    return np.array([0.0, 0.0, 0.6]) + 2.5 * axes, axes


def test_batch_is_the_single_routine_on_any_thread_count():
    cA, aA = _sweep(3000)
    cB, aB = np.array([0.3, -0.8, 0.4]), np.array([0.0, 1.0, 0.0])
    threads = get_num_threads()
    try:
        for nrm in (np.zeros(3), np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])):
            set_num_threads(1)
            one = cylinders_distance_batch(cA, aA, 2.5, 0.08, cB, aB, 0.45, 0.3, nrm, 1e-9)
            set_num_threads(2)
            two = cylinders_distance_batch(cA, aA, 2.5, 0.08, cB, aB, 0.45, 0.3, nrm, 1e-9)
            np.testing.assert_array_equal(one.view(np.int64), two.view(np.int64))
            single = [gjk_distance(cA[i], aA[i], 2.5, 0.08, cB, aB, 0.45, 0.3, *nrm, 1e-9) for i in range(0, 3000, 97)]
            np.testing.assert_array_equal(one[::97], single)
            assert (one <= 1e-9).any() and (one > 1e-9).any()
    finally:
        set_num_threads(threads)


def test_inputs_it_takes():
    cA, aA = _sweep(50, seed=1)
    cB, aB = np.array([0.3, -0.8, 0.4]), np.array([0.0, 1.0, 0.0])
    ref = cylinders_intersect(cA, aA, 2.5, 0.08, cB, aB, 0.45, 0.3)
    ro, fo = cA.copy(), np.asfortranarray(aA)
    ro.flags.writeable = False
    np.testing.assert_array_equal(cylinders_intersect(ro, fo, 2.5, 0.08, tuple(cB), [0, 1, 0], 0.45, 0.3), ref)
    np.testing.assert_array_equal(cylinders_distance_batch(ro, fo, 2.5, 0.08, cB, aB, 0.45, 0.3, np.zeros(3), 1e-9),
                                  cylinders_distance_batch(cA, aA, 2.5, 0.08, cB, aB, 0.45, 0.3, np.zeros(3), 1e-9))
    assert gjk_distance([0, 0, 1], [1, 0, 0], 1, 0.1, np.zeros(3), np.array([0, 1, 0]), 1, 0.5, 0, 0, 0, 1e-9) > 0.3
    empty = np.zeros((0, 3))
    assert cylinders_intersect(empty, empty, 1.0, 0.1, cB, aB, 0.4, 0.3).shape == (0,)
    assert projections_overlap(empty, empty, 1.0, 0.1, cB, aB, 0.4, 0.3).shape == (0,)


def test_non_finite_gram_systems_raise_linalg_error():
    args = (np.array([0, 0, 0.5]), np.array([1.0, 0, 0]), 1e200, 0.1, np.zeros(3), np.array([0, 1.0, 0]), 0.4, 0.3)
    with pytest.raises(np.linalg.LinAlgError):
        gjk_distance(*args, 0.0, 0.0, 0.0, 1e-9, False)
    # a NaN centre never reaches a Gram system: the answer is 0 (contact)
    assert cylinders_distance_batch(np.array([[np.nan, 0, 0]]), np.array([[1.0, 0, 0]]), 1.0, 0.1, np.zeros(3),
                                    np.array([0, 1.0, 0]), 0.4, 0.3, np.zeros(3), 1e-9)[0] == 0.0
