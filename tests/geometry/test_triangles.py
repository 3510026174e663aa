"""The exact triangle-triangle test and the triangle distance against their independent oracles,
closed forms and invariances."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tankcd_cli.geometry.triangles import tri_distance, tri_distance_brute, tri_tri, tri_tri_brute


def _on_triangle(point, T, tol=1e-9):
    """Whether ``point`` lies on the closed triangle T (within tol of its plane, barycentrics >= -tol)."""
    e1, e2 = T[1] - T[0], T[2] - T[0]
    n = np.cross(e1, e2)
    if abs((point - T[0]) @ n) > tol * np.linalg.norm(n) * max(1.0, np.abs(T).max()):
        return False
    u, v = np.linalg.lstsq(np.column_stack([e1, e2]), point - T[0], rcond=None)[0]
    return u >= -tol and v >= -tol and u + v <= 1 + tol


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from(["random", "coplanar", "shared_edge", "shared_vertex", "translated"]))
def test_property_triangle_test_matches_oracle_and_is_symmetric(seed, case):
    rng = np.random.default_rng(seed)
    P, Q = rng.normal(0, 1, (3, 3)), rng.normal(0, 1, (3, 3))
    if case == "coplanar":
        P[:, 2] = Q[:, 2] = 0.0
    elif case == "shared_edge":
        Q[:2] = P[:2]
    elif case == "shared_vertex":
        Q[0] = P[0]
    elif case == "translated":
        Q = P + rng.normal(0, 0.5, 3)
    out = np.empty(3)
    a = tri_tri(P, Q, out)
    assert a == tri_tri(Q, P, out) == tri_tri_brute(P, Q)
    # a common rigid motion changes nothing
    Rm = Rotation.random(random_state=seed % 1000).as_matrix()
    shift = rng.normal(0, 100, 3)
    assert tri_tri(P @ Rm.T + shift, Q @ Rm.T + shift, out) == a or case in ("shared_edge", "shared_vertex", "coplanar")


def test_tri_tri_takes_any_array_like_and_fills_scratch():
    P = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0]])  # integers
    Q = np.array([[0.5, 0.5, -1], [0.5, 0.5, 1], [1.5, 1.5, 0]])
    out = np.zeros(3, np.float32)
    assert tri_tri(P, Q, out) is True and out.tolist() == [0.75, 0.75, 0.0]  # the middle of the overlap
    out64 = np.empty(3)
    scratch = np.zeros((6, 3))
    Qr = np.asfortranarray(Q)
    Qr.flags.writeable = False
    assert tri_tri(P.astype(float), Qr, out64, scratch)
    np.testing.assert_array_equal(out64, out)
    assert scratch.any()  # the working space given was used
    assert not tri_tri(P, Q + [0, 0, 5], out64)
    assert tri_tri(P, Q, out64) == tri_tri_brute(P, Q)


def test_the_common_point_lies_on_both_triangles():
    rng = np.random.default_rng(5)
    out = np.empty(3)
    met = 0
    for _ in range(400):
        P = rng.normal(0, 1, (3, 3))
        Q = rng.normal(0, 1, (3, 3)) + rng.normal(0, 0.5, 3)
        if tri_tri(P, Q, out):
            met += 1
            assert _on_triangle(out, P) and _on_triangle(out, Q), (P, Q, out)
    assert met > 50
    # coplanar overlap: the point is shared too
    T = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0]], float)
    assert tri_tri(T, T + [0.5, 0.5, 0], out) and _on_triangle(out, T) and _on_triangle(out, T + [0.5, 0.5, 0])


@pytest.mark.parametrize("scale", [1e-4, 1e3, 1e6])
def test_the_answer_does_not_depend_on_the_unit(scale):
    """Moller's epsilon is relative to the triangles' size: millimetres or kilometres, the same answers,
    and touching stays touching."""
    rng = np.random.default_rng(6)
    out = np.empty(3)
    for _ in range(200):
        P = rng.normal(0, 1, (3, 3))
        Q = rng.normal(0, 1, (3, 3)) + rng.normal(0, 0.7, 3)
        assert tri_tri(P * scale, Q * scale, out) == tri_tri(P, Q, out) == tri_tri_brute(P * scale, Q * scale)
    T = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    above = np.array([[0.2, 0.2, 0.0], [0.3, 0.2, 1.0], [0.2, 0.3, 1.0]])  # a vertex resting on T
    assert tri_tri(T * scale, above * scale, out) and tri_tri(above * scale, T * scale, out)
    assert not tri_tri(T * scale, (above + [0, 0, 1e-6]) * scale, out)


def test_triangle_distance_against_its_oracle_and_hard_cases():
    rng = np.random.default_rng(2)
    for _ in range(60):
        P = rng.normal(size=(3, 3))
        Q = rng.normal(size=(3, 3)) + rng.normal(size=3) * 2
        d, a, b = tri_distance(P, Q)
        assert d == pytest.approx(np.linalg.norm(a - b), abs=1e-12)
        truth = tri_distance_brute(P, Q)  # the oracle's optimiser is the slow part: once per pair
        assert d <= truth + 1e-9  # attained by points on both: never above the truth
        assert d >= truth - 1e-6  # and the oracle's optimiser is good to about 1e-7
    T = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    assert tri_distance(T, T + [0, 0, 0.25])[0] == pytest.approx(0.25)  # parallel, stacked
    assert tri_distance(T, T)[0] == 0  # coplanar, identical
    assert tri_distance(T, T + [1.0, 0, 0])[0] == 0  # sharing a vertex
    assert tri_distance(T, -T + [2.0, 2.0, 0])[0] == pytest.approx(np.sqrt(2))  # hypotenuses x + y = 1 and 3
    far = T + [1e6, 4.5e6, 100.0]  # UTM-sized coordinates: differences keep the precision
    assert tri_distance(far, far + [0, 0, 1e-4])[0] == pytest.approx(1e-4, rel=1e-6)
    flat = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], float)  # no area: meets nothing
    assert tri_distance(flat, T)[0] == np.inf


def test_triangle_distance_closed_forms_and_its_points():
    # edge against edge: two crossed fins, the lower's top edge along x, the upper's bottom edge along y
    lower = np.array([[-1, 0, 0], [1, 0, 0], [0, 0, -1]], float)
    upper = np.array([[0, -1, 0.3], [0, 1, 0.3], [0, 0, 1.3]])
    d, a, b = tri_distance(lower, upper)
    assert d == pytest.approx(0.3)
    np.testing.assert_allclose(a, [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(b, [0, 0, 0.3], atol=1e-12)
    # a vertex above the inside of a face: the height
    T = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0]], float)
    spike = np.array([[1, 1, 0.7], [1.5, 1, 3], [1, 1.5, 3]])
    d, a, b = tri_distance(T, spike)
    assert d == pytest.approx(0.7)
    np.testing.assert_allclose(a, [1, 1, 0], atol=1e-12)
    np.testing.assert_allclose(b, [1, 1, 0.7], atol=1e-12)


def test_triangle_distance_is_symmetric_zero_exactly_when_they_meet_and_its_points_lie_on_them():
    rng = np.random.default_rng(8)
    out = np.empty(3)
    met = 0
    for _ in range(300):
        P = rng.normal(0, 1, (3, 3))
        Q = rng.normal(0, 1, (3, 3)) + rng.normal(0, 0.6, 3)
        d, a, b = tri_distance(P, Q)
        e, b2, a2 = tri_distance(Q, P)
        assert d == pytest.approx(e, abs=1e-12)
        assert _on_triangle(a, P) and _on_triangle(b, Q)
        assert (d == 0) == tri_tri(P, Q, out)
        met += d == 0
    assert 20 < met < 280  # both answers occur often
