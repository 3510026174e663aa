"""Region classes: thresholds from the chord error, footprint averaging, noise robustness."""

import numpy as np
import pytest

from tankcd_cli.io.terrain_readers import RawTerrain
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.classify import classify_terrain
from tankcd_cli.terrain.regions import FLAT, GENERAL, UNEVEN, Thresholds, default_thresholds
from tankcd_cli.vehicle import vehicle_preset


def raw(V, F, name="synthetic"):
    return RawTerrain(V, F, None, name, "0" * 64, "obj")


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


@pytest.mark.parametrize("radius,expected", [(1000.0, FLAT), (60.0, GENERAL), (15.0, UNEVEN)])
def test_sphere_caps_classify_by_their_curvature(radius, expected):
    t = default_thresholds(vehicle_preset("t72"))
    assert {1000.0: 1 / 1000 < t.flat, 60.0: t.flat < 1 / 60 < t.uneven, 15.0: 1 / 15 > t.uneven}[radius]
    V, F, xy = S.grid_mesh(S.sphere_cap(radius), min(10.0, radius * 0.6), 0.5)
    store = classify_terrain(raw(V, F))
    centre = np.hypot(xy[:, 0], xy[:, 1]) < 3
    assert (store.vertex_class[centre] == expected).all()


def test_exactly_flat_and_tilted_ground_is_flat():
    for field in (S.plane(), S.plane(0.2, 0.1, 50.0)):
        V, F, _ = S.grid_mesh(field, 30.0, 1.0, offset=(500000.0, 4500000.0, 0.0))
        store = classify_terrain(raw(V, F))
        assert (store.vertex_class == FLAT).all()
        assert store.attrs["share_flat"] == pytest.approx(1.0)
        assert (store.class_raster[store.class_raster != 255] == FLAT).all()


def test_quantized_heights_do_not_make_flat_ground_general():
    """1 cm terraces and 2 mm noise at 1 m spacing stay flat (the footprint average removes them)."""
    rng = np.random.default_rng(4)
    V, F, _ = S.grid_mesh(S.plane(0.03, 0.01), 40.0, 1.0)
    V[:, 2] = np.round(V[:, 2] + rng.normal(0, 0.002, len(V)), 2)
    store = classify_terrain(raw(V, F))
    interior = np.max(np.abs(V[:, :2]), axis=1) < 35
    assert np.mean(store.vertex_class[interior] == FLAT) > 0.99


def test_crater_is_uneven_plain_around_is_flat():
    """A crater (bowl and rim) is uneven although its signed curvature changes sign."""
    x = np.arange(-40, 41, 1.0)
    X, Y = np.meshgrid(x, x)
    r = np.hypot(X, Y)
    Z = np.where(r < 5, -1.5 * (1 - (r / 5) ** 2) ** 2, 0) + 0.4 * np.exp(-((r - 5) / 1.5) ** 2)
    from tankcd_cli.io.terrain_readers import grid_faces

    V = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    F = grid_faces(np.arange(V.shape[0]).reshape(X.shape))
    store = classify_terrain(raw(V, F))
    cls = store.vertex_class
    assert (cls[r.ravel() < 6] == UNEVEN).all()
    assert (cls[r.ravel() > 18] == FLAT).all()


def test_user_thresholds_and_validation():
    V, F, _ = S.grid_mesh(S.sphere_cap(60.0), 10.0, 0.5)
    store = classify_terrain(raw(V, F), thresholds=Thresholds(0.0, 0.001))
    assert (store.vertex_class == UNEVEN).all()
    with pytest.raises(ValueError):
        Thresholds(0.02, 0.01)
    with pytest.raises(ValueError):
        Thresholds(float("nan"), 0.01)


def test_raster_agrees_with_vertices():
    V, F, xy = S.grid_mesh(S.sinusoid(1.5, 40, 60), 40.0, 1.0)
    store = classify_terrain(raw(V, F))
    from tankcd_cli.terrain.regions import Raster

    r = Raster(store.raster_origin, store.raster_cell, store.class_raster)
    row, col = r.cell_of(V[:, :2])
    assert np.mean(store.class_raster[row, col] == store.vertex_class) > 0.97
