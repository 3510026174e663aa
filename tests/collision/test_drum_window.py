"""The drum window, the internal check's gate: no barrel position it clears touches a drum, at any
elevation, for the presets and for random vehicles; a path it clears is one the exact walk finds
nothing on; and it clears most of the circle, so it is a gate and not a formality."""

import dataclasses

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tankcd_cli.collision.internal import (
    DrumWindow,
    drum_window,
    drum_window_clear,
    first_gun_contacts,
    gun_hits_drums,
)
from tankcd_cli.vehicle import vehicle_preset

AZIMUTHS = np.radians(np.arange(-180.0, 180.0, 0.05))


def _hit_anywhere(vehicle, azimuth, elevations=np.arange(-89.0, 89.1, 0.5)):
    """(N,) bool: the barrel at each azimuth touches a drum at some elevation of a dense set."""
    hit = np.zeros(len(azimuth), dtype=bool)
    for e in elevations:
        hit |= gun_hits_drums(vehicle, azimuth, np.full(len(azimuth), np.radians(e))).any(axis=1)
    return hit


def _clear_at(window, azimuth, elevation=0.0):
    n = len(azimuth)
    return drum_window_clear(window, azimuth, np.zeros(n), np.full(n, elevation), np.zeros(n))


@pytest.mark.parametrize("name", ["t72", "t55"])
def test_every_azimuth_a_drum_can_be_touched_from_lies_in_the_window_and_the_window_is_tight(name):
    vehicle = vehicle_preset(name)
    window = drum_window(vehicle)
    hit = _hit_anywhere(vehicle, AZIMUTHS)
    clear = _clear_at(window, AZIMUTHS)
    assert hit.any() and not (clear & hit).any()
    # the window is at most 12 deg wider than the azimuths that touch, and the gate clears most
    # of the circle (a window of every azimuth would pass the first assertion and prove nothing)
    assert np.degrees(2 * window.half_width) <= np.count_nonzero(hit) * 0.05 + 12.0
    assert clear.mean() > 0.8


def test_a_vehicle_without_drums_has_an_empty_window():
    window = drum_window(vehicle_preset("m1"))
    assert window.half_width < 0
    assert _clear_at(window, AZIMUTHS).all()


@settings(max_examples=60, deadline=None)
@given(turret_x=st.floats(-3.0, 0.5), trunnion_forward=st.floats(-0.6, 0.8), gun_length=st.floats(1.0, 8.0),
       gun_radius=st.floats(0.03, 0.3), drum_dx=st.floats(0.0, 1.5), drum_y=st.floats(0.0, 1.5),
       drum_z=st.floats(0.5, 2.0), drum_radius=st.floats(0.1, 0.5), drum_length=st.floats(0.2, 1.5))
@example(turret_x=-2.9, trunnion_forward=-0.8, gun_length=3.0, gun_radius=0.1, drum_dx=0.0, drum_y=0.5, drum_z=1.2,
         drum_radius=0.3, drum_length=0.88)  # the trunnion behind the turret axis reaches a drum pointing forward
def test_random_vehicles_no_position_the_window_clears_touches_a_drum(turret_x, trunnion_forward, gun_length,
                                                                     gun_radius, drum_dx, drum_y, drum_z,
                                                                     drum_radius, drum_length):
    t72 = vehicle_preset("t72")
    vehicle = dataclasses.replace(t72, turret_x=turret_x, trunnion_forward=trunnion_forward, gun_length=gun_length,
                                  gun_radius=gun_radius, drum_x=-t72.hull_length / 2 - drum_dx, drum_y=drum_y,
                                  drum_z=drum_z, drum_radius=drum_radius, drum_length=drum_length)
    window = drum_window(vehicle)
    az = np.radians(np.arange(-180.0, 180.0, 0.25))
    clear = _clear_at(window, az)
    hit = _hit_anywhere(vehicle, az, np.arange(-85.0, 85.1, 2.5))
    assert not (clear & hit).any()


@settings(max_examples=200, deadline=None)
@given(az0=st.floats(-400, 400), daz=st.floats(-800, 800), el0=st.floats(-10, 20), dele=st.floats(-20, 20))
def test_a_path_the_window_clears_is_one_the_exact_walk_finds_nothing_on(az0, daz, el0, dele):
    t72 = vehicle_preset("t72")
    a0, da, e0, de = np.radians([az0, daz, el0, dele])
    window = drum_window(t72)
    clear = drum_window_clear(window, [a0], [da], [e0], [de])[0]
    # the path's azimuths, densely: clear exactly when none lies in the window (to the sampling)
    s = np.linspace(0.0, 1.0, 20001)
    off = np.abs((a0 + s * da - window.centre + np.pi) % (2 * np.pi) - np.pi)
    if clear:
        assert (off > window.half_width).all()
        found, _, _ = first_gun_contacts(t72, [a0], [da], [e0], [de])
        assert not found[0]
    else:
        step = abs(da) / 20000
        assert off.min() <= window.half_width + step


def test_paths_with_nan_or_the_gun_past_vertical_are_never_cleared():
    window = drum_window(vehicle_preset("t72"))
    a = np.radians([0.0, 0.0, 0.0, np.nan])
    clear = drum_window_clear(window, a, [0.0, 0.0, np.nan, 0.0], np.radians([0.0, 95.0, 0.0, 0.0]),
                              np.radians([0.0, 0.0, 0.0, 0.0]))
    assert clear.tolist() == [True, False, False, False]
    # a path turning all the way round always meets the window
    assert not drum_window_clear(window, [0.0], [2 * np.pi], [0.0], [0.0])[0]
    # the window of every azimuth clears nothing
    assert not drum_window_clear(DrumWindow(0.0, np.pi), [0.0], [0.0], [0.0], [0.0])[0]


def test_the_window_straddles_the_rear_and_a_path_across_it_either_way_is_not_cleared():
    window = drum_window(vehicle_preset("t72"))
    assert abs(abs(window.centre) - np.pi) < 1e-9
    for a0, da in ((170.0, 20.0), (-170.0, -20.0), (150.0, 60.0), (-150.0, -60.0), (90.0, 200.0)):
        assert not drum_window_clear(window, np.radians([a0]), np.radians([da]), [0.0], [0.0])[0], (a0, da)
    for a0, da in ((-90.0, 180.0), (120.0, -240.0), (0.0, 0.0)):
        assert drum_window_clear(window, np.radians([a0]), np.radians([da]), [0.0], [0.0])[0], (a0, da)
