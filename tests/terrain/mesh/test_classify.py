"""Classifying a mesh: classes from the closed-form curvature of known shapes, noise that stays
flat, user thresholds, and what the store's attributes record."""

import numpy as np
import pytest

from tankcd_cli.io.terrain_readers import RawTerrain
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.mesh.classify import classify_mesh
from tankcd_cli.terrain.regions import FLAT, GENERAL, UNEVEN, Thresholds, default_thresholds
from tankcd_cli.vehicle import vehicle_preset


def raw(V, F, name="synthetic"):
    return RawTerrain(V, F, None, name, "0" * 64, "obj")


@pytest.mark.parametrize("radius,expected", [(1000.0, FLAT), (60.0, GENERAL), (15.0, UNEVEN)])
def test_sphere_caps_classify_by_their_curvature(radius, expected):
    t = default_thresholds(vehicle_preset("t72"))
    assert {1000.0: 1 / 1000 < t.flat, 60.0: t.flat < 1 / 60 < t.uneven, 15.0: 1 / 15 > t.uneven}[radius]
    V, F, xy = S.grid_mesh(S.sphere_cap(radius), min(10.0, radius * 0.6), 0.5)
    store = classify_mesh(raw(V, F))
    centre = np.hypot(xy[:, 0], xy[:, 1]) < 3
    assert (store.vertex_class[centre] == expected).all()


def test_exactly_flat_and_tilted_ground_is_flat():
    for field in (S.plane(), S.plane(0.2, 0.1, 50.0)):
        V, F, _ = S.grid_mesh(field, 30.0, 1.0, offset=(500000.0, 4500000.0, 0.0))
        store = classify_mesh(raw(V, F))
        assert (store.vertex_class == FLAT).all()
        assert store.attrs["share_flat"] == pytest.approx(1.0)
        assert (store.class_raster[store.class_raster != 255] == FLAT).all()


def test_quantized_heights_do_not_make_flat_ground_general():
    """1 cm terraces and 2 mm noise at 1 m spacing stay flat (the footprint average removes them)."""
    rng = np.random.default_rng(4)
    V, F, _ = S.grid_mesh(S.plane(0.03, 0.01), 40.0, 1.0)
    V[:, 2] = np.round(V[:, 2] + rng.normal(0, 0.002, len(V)), 2)
    store = classify_mesh(raw(V, F))
    interior = np.max(np.abs(V[:, :2]), axis=1) < 35
    assert np.mean(store.vertex_class[interior] == FLAT) > 0.99


def test_user_thresholds():
    V, F, _ = S.grid_mesh(S.sphere_cap(60.0), 10.0, 0.5)
    store = classify_mesh(raw(V, F), thresholds=Thresholds(0.0, 0.001))
    assert (store.vertex_class == UNEVEN).all()
