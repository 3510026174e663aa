"""Opening and classifying any terrain through terrain.open: what each input is, the surface and
store each gives, the cache beside the input, the options that do not apply, and one decision
behind both open_terrain and classify_file."""

import hashlib
import os

import h5py
import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.grid.surface import GridSurface
from tankcd_cli.terrain.mesh.surface import MeshSurface
from tankcd_cli.terrain.open import TERRAIN_KINDS, OptionError, classify_file, open_dem, open_terrain, terrain_kind
from tankcd_cli.terrain.store import read_attrs, store_layout
from tankcd_cli.terrain.surface import Surface
from tests.conftest import write_asc, write_obj

X0, Y0 = 500_000.0, 4_200_000.0


def hill(n=24):
    x = np.arange(n, dtype=float)
    return 2.0 * np.exp(-((x[None, :] - n / 2) ** 2 + (x[:, None] - n / 2) ** 2) / 40.0)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """One file of every kind: an ESRI grid, a GeoTIFF, a folder of tiles, an OBJ, both stores, a tree."""
    d = tmp_path_factory.mktemp("inputs")
    z = hill()
    asc = write_asc(d / "hill.asc", z, xll=X0, yll=Y0)
    V, F, _ = S.jittered_mesh(S.gaussian_hill(2.0, 4.0), 10.0, 1.0, seed=3, offset=(X0, Y0, 0.0))
    obj = write_obj(d / "tin.obj", V, F)
    import rasterio
    from rasterio.transform import from_origin

    tif = d / "hill.tif"
    profile = dict(driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype="float32",
                   transform=from_origin(X0 - 0.5, Y0 + z.shape[0] - 0.5, 1.0, 1.0))
    with rasterio.open(tif, "w", **profile) as dst:
        dst.write(z.astype(np.float32), 1)
    tiles = d / "tiles"
    tiles.mkdir()
    (tiles / "a.tif").write_bytes(tif.read_bytes())
    grid_store, mesh_store = d / "grid.h5", d / "mesh.h5"
    classify_file(str(asc), str(grid_store))
    classify_file(str(obj), str(mesh_store))
    tree = d / "tree.h5"
    with h5py.File(tree, "w") as h5:
        h5.attrs["format"] = "tankcd-bvh"
    return {"esri_ascii": asc, "raster": tif, "folder": tiles, "mesh": obj, "grid_store": grid_store,
            "mesh_store": mesh_store, "tree": tree}


@pytest.mark.parametrize("name,kind", [("esri_ascii", "esri_ascii"), ("raster", "raster"), ("folder", "raster"),
                                       ("mesh", "mesh"), ("grid_store", "grid_store"), ("mesh_store", "mesh_store")])
def test_terrain_kind_by_what_the_file_is(inputs, name, kind):
    assert terrain_kind(str(inputs[name])) == kind and kind in TERRAIN_KINDS


def test_terrain_kind_by_the_format_given(inputs):
    assert terrain_kind("-") == "mesh"
    assert terrain_kind("-", "asc") == "esri_ascii" and terrain_kind("-", "ASC") == "esri_ascii"
    assert terrain_kind("-", "tif") == terrain_kind("-", "dt1") == "raster"
    assert terrain_kind("-", "obj") == "mesh"
    assert terrain_kind(str(inputs["mesh"]), "asc") == "esri_ascii"  # the format named wins
    assert terrain_kind(str(inputs["grid_store"]), "h5") == "grid_store"
    with pytest.raises(InputError, match="not a tankcd terrain store"):
        terrain_kind(str(inputs["tree"]))


def test_open_dem_is_none_for_a_mesh(inputs):
    assert open_dem(str(inputs["mesh"])) is None and open_dem(str(inputs["mesh_store"])) is None
    with open_dem(str(inputs["esri_ascii"])) as dem:
        assert (dem.grid.rows, dem.grid.cols) == hill().shape
        assert dem.grid.south_west == (X0, Y0) and dem.info.format == "asc"


@pytest.mark.parametrize("name,layout,stored,classified", [
    ("grid_store", "grid", "itself", False), ("mesh_store", "mesh", "itself", False),
    ("esri_ascii", "grid", "temporary", True), ("raster", "grid", "temporary", True),
    ("mesh", "mesh", None, True)])
def test_open_terrain_of_every_kind(inputs, name, layout, stored, classified):
    opened = open_terrain(str(inputs[name]))
    assert isinstance(opened.surface, Surface)
    assert isinstance(opened.surface, GridSurface if layout == "grid" else MeshSurface)
    assert opened.layout == layout and opened.classified == classified and opened.source == str(inputs[name])
    assert (opened.mesh_store is not None) == (layout == "mesh")
    if stored == "itself":
        assert opened.store_path == str(inputs[name])
    elif stored == "temporary":
        assert os.path.isfile(opened.store_path) and os.path.dirname(opened.store_path) != str(inputs[name].parent)
        assert store_layout(opened.store_path) == "grid"
    else:
        assert opened.store_path is None
    z, _, on = opened.surface.height_normal(np.array([X0 + 5.0]), np.array([Y0 + 5.0]))
    assert on[0] and np.isfinite(z[0])


@pytest.mark.parametrize("name", ["esri_ascii", "mesh"])
def test_the_cache_beside_the_input_is_written_then_read(tmp_path, inputs, name):
    src = tmp_path / inputs[name].name
    src.write_bytes(inputs[name].read_bytes())
    stages = []
    first = open_terrain(str(src), cache=True, progress=stages.append)
    cached = str(tmp_path / (src.stem + ".h5"))
    assert first.classified and first.store_path == cached and os.path.isfile(cached)
    assert read_attrs(cached)["source_sha256"] == hashlib.sha256(src.read_bytes()).hexdigest()
    again = open_terrain(str(src), cache=True, progress=stages.append)
    assert not again.classified and again.store_path == cached and stages[-1] == f"reading cached store {cached}"
    before = os.path.getmtime(cached)
    src.write_bytes(src.read_bytes() + b"\n")  # other bytes: classified again
    assert open_terrain(str(src), cache=True).classified
    assert os.path.getmtime(cached) >= before


@pytest.mark.parametrize("name,layout", [("esri_ascii", "grid"), ("raster", "grid"), ("folder", "grid"),
                                         ("mesh", "mesh"), ("grid_store", "grid"), ("mesh_store", "mesh")])
def test_classify_file_decides_as_open_terrain_does(tmp_path, inputs, name, layout):
    out = tmp_path / "out.h5"
    seen = []
    done = classify_file(str(inputs[name]), str(out),
                         on_grid=lambda grid, info: seen.append((grid, info)),
                         before_commit=lambda tmp, d: seen.append((os.path.isfile(tmp), out.exists(), d.layout)))
    assert done.layout == layout == store_layout(str(out))
    if name != "folder":
        assert open_terrain(str(inputs[name])).layout == layout
    assert seen[-1] == (True, False, layout)  # the store complete under its temporary name, not yet renamed
    if layout == "grid":
        grid, info = seen[0]
        assert done.grid == grid and (grid.rows, grid.cols) == hill().shape and done.mesh_store is None
        assert done.method == "grid" and done.attrs["valid_posts"] == grid.rows * grid.cols
    else:
        assert len(seen) == 1 and done.grid is None and done.method == "jet"
        assert len(done.mesh_store.vertices) == done.attrs["vertices_read"] - done.attrs["merged_vertices"] \
            - done.attrs["unreferenced_vertices"]


def test_a_mesh_store_is_classified_again_with_other_settings(tmp_path, inputs):
    out = tmp_path / "again.h5"
    done = classify_file(str(inputs["mesh_store"]), str(out), method="cotan")
    assert done.method == "cotan" and read_attrs(str(out))["curvature_method"] == "cotan"
    assert done.source == read_attrs(str(inputs["mesh_store"]))["source"]  # the store's own source


@pytest.mark.parametrize("name,kwargs,message", [
    ("esri_ascii", {"up": "y"}, "--up y makes no sense for a DEM"),
    ("mesh", {"scheduler": "tcp://127.0.0.1:1"}, "--scheduler applies to DEMs"),
    ("mesh", {"crs": "EPSG:32633"}, "--crs and --band apply to DEM rasters"),
    ("mesh", {"band": 2}, "--crs and --band apply to DEM rasters"),
    ("mesh", {"method": "grid"}, "--method grid needs a DEM"),
    ("mesh_store", {"method": "grid"}, "--method grid needs a DEM"),
])
def test_options_that_do_not_apply(tmp_path, inputs, name, kwargs, message):
    out = tmp_path / "never.h5"
    with pytest.raises(OptionError, match=message):
        classify_file(str(inputs[name]), str(out), **kwargs)
    assert not out.exists()


def test_a_scheduler_needs_a_dem_path_not_standard_input(monkeypatch, tmp_path, inputs):
    import io
    import sys

    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(inputs["esri_ascii"].read_bytes())))
    with pytest.raises(OptionError, match="--scheduler needs a DEM path"):
        classify_file("-", str(tmp_path / "x.h5"), fmt="asc", scheduler="tcp://127.0.0.1:1")
