"""The mesh layout of the store: every array and attribute round-trips, and a store that is not
one (a grid layout, an older version, damaged indices) is a one-line InputError."""

import h5py
import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.mesh.classify import classify_mesh
from tankcd_cli.terrain.mesh.store import read_mesh_store, write_mesh_store
from tankcd_cli.terrain.store import FORMAT, FORMAT_VERSION, read_attrs, store_layout

ARRAYS = ("vertices", "faces", "mean_curvature", "footprint_curvature", "vertex_class", "class_raster",
          "footprint_raster", "raster_origin")


def _stores():
    V, F, _ = S.jittered_mesh(S.gaussian_hill(2.0, 5.0), 8.0, 1.0, seed=2, offset=(500_000.0, 4_500_000.0, 10.0))
    z = np.add.outer(np.arange(12.0), np.arange(15.0)) * 0.1
    z[3, 4] = np.nan
    return {"tin": classify_mesh(S.mesh_terrain(V, F)), "dem": classify_mesh(S.dem_terrain(z, origin=(100.0, 200.0)))}


@pytest.mark.parametrize("kind", ["tin", "dem"])
def test_round_trip(tmp_path, kind):
    store = _stores()[kind]
    path = str(tmp_path / "t.h5")
    write_mesh_store(path, store)
    back = read_mesh_store(path)
    for name in ARRAYS:
        np.testing.assert_array_equal(getattr(back, name), getattr(store, name), err_msg=name)
    assert back.raster_cell == store.raster_cell
    assert (back.buckets is None) == (kind == "dem") and (back.grid is None) == (kind == "tin")
    if kind == "tin":
        for name in ("origin", "start", "face"):
            np.testing.assert_array_equal(getattr(back.buckets, name), getattr(store.buckets, name))
        assert back.buckets.shape == store.buckets.shape and back.buckets.cell == store.buckets.cell
    else:
        np.testing.assert_array_equal(back.grid.vertex, store.grid.vertex)
    attrs = read_attrs(path)
    assert attrs["format"] == FORMAT and attrs["format_version"] == FORMAT_VERSION
    assert store_layout(path) == "mesh"
    for key, value in store.attrs.items():
        assert np.all(np.asarray(back.attrs[key]) == np.asarray(value)), key


def test_what_is_not_a_mesh_store_is_refused(tmp_path):
    store = _stores()["tin"]
    path = str(tmp_path / "t.h5")
    write_mesh_store(path, store)
    with h5py.File(path, "a") as h5:
        h5["mesh/faces"][0, 0] = len(store.vertices)  # past the last vertex
    with pytest.raises(InputError, match="damaged tankcd terrain store: face indices"):
        read_mesh_store(path)
    with h5py.File(path, "a") as h5:
        h5.attrs["format_version"] = FORMAT_VERSION - 1
    with pytest.raises(InputError, match="run classify again"):
        read_mesh_store(path)
    with h5py.File(path, "a") as h5:
        h5.attrs["format_version"] = FORMAT_VERSION
        h5.attrs["layout"] = "grid"
    with pytest.raises(InputError, match="read by window"):
        read_mesh_store(path)
