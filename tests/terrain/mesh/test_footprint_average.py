"""Footprint averaging on a mesh: vertex areas, the averaged |H| against closed forms, the
crater whose signed curvature would cancel, and the class raster against the vertices."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
import pytest

from tankcd_cli.io.terrain_readers import RawTerrain
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.mesh.classify import classify_mesh
from tankcd_cli.terrain.mesh.footprint_average import Raster, footprint_curvature, vertex_areas
from tankcd_cli.terrain.regions import FLAT, UNEVEN
from tankcd_cli.vehicle import vehicle_preset


def raw(V, F, name="synthetic"):
    return RawTerrain(V, F, None, name, "0" * 64, "obj")


def test_vertex_areas_are_a_third_of_each_face():
    """Two right triangles of area 1/2 on the unit square: corners shared by both get 1/3."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2], [0, 2, 3]])
    np.testing.assert_allclose(vertex_areas(V, F), [1 / 3, 1 / 6, 1 / 3, 1 / 6])
    V, F, _ = S.jittered_mesh(S.gaussian_hill(3.0, 6.0), 8.0, 1.0, seed=1)
    p = V[F]
    total = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    assert vertex_areas(V, F).sum() == pytest.approx(total, rel=1e-12)


def test_a_constant_curvature_averages_to_itself():
    """On a sphere cap H = 1/R everywhere: both disk averages give 1/R at every vertex and cell
    the footprint's disk covers fully."""
    R = 40.0
    V, F, xy = S.grid_mesh(S.sphere_cap(R), 20.0, 0.5)
    H = np.full(len(V), 1 / R)
    at_vertex, raster = footprint_curvature(V, H, vertex_areas(V, F), vehicle_preset("t72"))
    inner = np.max(np.abs(xy), axis=1) < 20.0 - vehicle_preset("t72").track_length
    np.testing.assert_allclose(at_vertex[inner], 1 / R, rtol=1e-9)
    assert raster.cell == pytest.approx(vehicle_preset("t72").track_length / 8)
    assert np.nanmax(raster.values) == pytest.approx(1 / R, rel=1e-9)


def test_crater_is_uneven_plain_around_is_flat():
    """A crater (bowl and rim) is uneven although its signed curvature changes sign."""
    x = np.arange(-40, 41, 1.0)
    X, Y = np.meshgrid(x, x)
    r = np.hypot(X, Y)
    Z = np.where(r < 5, -1.5 * (1 - (r / 5) ** 2) ** 2, 0) + 0.4 * np.exp(-((r - 5) / 1.5) ** 2)
    from tankcd_cli.geometry.post_grid import grid_faces

    V = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    F = grid_faces(np.arange(V.shape[0]).reshape(X.shape))
    store = classify_mesh(raw(V, F))
    cls = store.vertex_class
    assert (cls[r.ravel() < 6] == UNEVEN).all()
    assert (cls[r.ravel() > 18] == FLAT).all()


def test_raster_agrees_with_vertices():
    V, F, xy = S.grid_mesh(S.sinusoid(1.5, 40, 60), 40.0, 1.0)
    store = classify_mesh(raw(V, F))

    r = Raster(store.raster_origin, store.raster_cell, store.class_raster)
    row, col = r.cell_of(V[:, :2])
    assert np.mean(store.class_raster[row, col] == store.vertex_class) > 0.97


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), st.floats(1.0, 4.99), st.integers(0, 2**32 - 1))
def test_the_direct_disk_sum_is_ndimages_bit_for_bit(rows, cols, radius, seed):
    """The disks of up to 81 cells are summed without scipy, in its order: the same bits as
    ``scipy.ndimage.convolve`` (the oracle), grids smaller than the disk included."""
    from scipy.ndimage import convolve

    from tankcd_cli.terrain.mesh.footprint_average import _direct_disk_sum, _disk

    rng = np.random.default_rng(seed)
    grid = rng.normal(size=(rows, cols)) * rng.uniform(0, 1e3, (rows, cols)) * (rng.random((rows, cols)) < 0.7)
    kernel = _disk(radius)
    assert kernel.size <= 81
    np.testing.assert_array_equal(_direct_disk_sum(grid, kernel), convolve(grid, kernel, mode="constant"))
