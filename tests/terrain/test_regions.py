"""Region classes: thresholds from the chord error, and the classes of averaged values."""

import numpy as np
import pytest

from tankcd_cli.terrain.regions import FLAT, GENERAL, UNEVEN, Thresholds, classify_values, default_thresholds
from tankcd_cli.vehicle import vehicle_preset


def test_default_thresholds_follow_the_chord_error_derivation():
    t72 = vehicle_preset("t72")
    t = default_thresholds(t72)
    # a cylinder crest of curvature k = 2H across the track: chord error k L^2 / 8 = H L^2 / 4
    L = t72.track_length
    assert t.flat * L**2 / 4 == pytest.approx(0.02)
    assert t.uneven * L**2 / 4 == pytest.approx(0.10)
    # a longer track bridges more: lower thresholds
    assert default_thresholds(vehicle_preset("m1")).flat < t.flat


def test_chord_error_really_is_h_l2_over_4_on_a_cylinder():
    """The derivation checked on geometry: sagitta of a chord of length L on a circle of radius R."""
    L = vehicle_preset("t72").track_length
    for R in (50.0, 200.0):
        sagitta = R - np.sqrt(R * R - (L / 2) ** 2)
        H = 1 / (2 * R)
        assert sagitta == pytest.approx(H * L**2 / 4, rel=1e-3)


def test_threshold_validation():
    with pytest.raises(ValueError):
        Thresholds(0.02, 0.01)
    with pytest.raises(ValueError):
        Thresholds(float("nan"), 0.01)


def test_classify_values_at_and_around_the_boundaries():
    """Flat below ``flat``, uneven at or above ``uneven``, general in between, whatever the shape."""
    t = Thresholds(0.01, 0.02)
    values = np.array([[0.0, 0.0099999, 0.01], [0.015, 0.0199999, 0.02], [0.5, np.inf, 1e-300]])
    np.testing.assert_array_equal(classify_values(values, t),
                                  [[FLAT, FLAT, GENERAL], [GENERAL, GENERAL, UNEVEN], [UNEVEN, UNEVEN, FLAT]])
    assert classify_values(values, t).dtype == np.uint8
