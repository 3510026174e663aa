"""Vehicle presets and the ground samples the key-point matchers take from them."""

import numpy as np
import pytest

from tankcd_cli.matching.match import match
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.vehicle import PRESETS, vehicle_preset, wheel_stations


@pytest.mark.parametrize("name,wheels", [("t72", 6), ("t55", 5), ("m1", 7)])
def test_wheel_stations_span_each_track_at_both_edges(name, wheels):
    v = PRESETS[name]
    assert v.road_wheels == wheels
    pts = wheel_stations(v)
    assert pts.shape == (4 * wheels, 2)
    h, g, w = v.track_length / 2, v.track_gauge / 2, v.track_width / 2
    np.testing.assert_allclose(sorted(set(np.round(pts[:, 0], 12))), np.linspace(-h, h, wheels), atol=1e-12)
    np.testing.assert_allclose(sorted(set(np.round(np.abs(pts[:, 1]), 12))), [g - w, g + w], atol=1e-12)
    left, right = pts[: 2 * wheels], pts[2 * wheels:]
    np.testing.assert_array_equal(left[:, 0], right[:, 0])
    np.testing.assert_array_equal(left[:, 1], -right[:, 1])


@pytest.mark.parametrize("bad", [True, 1, 21, 2.5, "6"])
def test_road_wheels_must_be_a_whole_number_in_range(bad):
    with pytest.raises(ValueError, match="road_wheels"):
        vehicle_preset("t72", road_wheels=bad)


def test_wheel_stations_rest_on_a_tilted_plane_exactly():
    x = np.arange(0, 41.0)
    X, Y = np.meshgrid(x, x)
    surface = S.surface_of(S.dem_terrain(100 + 0.08 * X - 0.15 * Y, origin=(500_000.0, 4_500_000.0)))
    rng = np.random.default_rng(4)
    n = 50
    px, py, yaw = 500_000.0 + rng.uniform(8, 32, n), 4_500_000.0 + rng.uniform(8, 32, n), rng.uniform(-np.pi, np.pi, n)
    p = match(surface, vehicle_preset("t72", road_wheels=9), px, py, yaw, "wheel_stations")
    ref = match(surface, vehicle_preset("t72"), px, py, yaw, "reference")
    np.testing.assert_allclose(p.position, ref.position, atol=1e-9)
    np.testing.assert_allclose(p.quaternion, ref.quaternion, atol=1e-9)
