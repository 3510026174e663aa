"""Classifying a DEM source into a grid store: the attributes it records against the posts
themselves, the same store whatever the threads and tiles, and the grids it refuses."""

import h5py
import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.dem_source import DemSourceInfo
from tankcd_cli.terrain.grid.classify import classify_dem
from tankcd_cli.terrain.grid.sources import ArrayDem
from tankcd_cli.terrain.store import read_attrs, store_layout

X0, Y0 = 500_000.0, 4_200_000.0


def dem(rows=45, cols=52, seed=0):
    rng = np.random.default_rng(seed)
    z = 80 + np.cumsum(rng.normal(0, 0.2, (rows, cols)), axis=1) + np.cumsum(rng.normal(0, 0.2, (rows, cols)), axis=0)
    z[10:14, 20:27] = np.nan
    grid = PostGrid(rows, cols, X0, Y0 + (rows - 1) * 2.0, 2.0, 2.0, "", "local grid (no CRS)")
    return ArrayDem(z, grid, DemSourceInfo("mem.asc", "asc", sha256="ab" * 32)), z, grid


def test_the_attributes_it_records(tmp_path):
    source, z, grid = dem()
    path = str(tmp_path / "g.h5")
    seen = []
    attrs = classify_dem(source, path, tile=16, jobs=1, progress=lambda *a: seen.append(a))
    assert store_layout(path) == "grid"
    assert attrs["rows"] == 45 and attrs["cols"] == 52 and attrs["diagonal"] == "SW-NE"
    assert attrs["valid_posts"] == np.isfinite(z).sum() and attrs["nodata_posts"] == np.isnan(z).sum()
    west, south, east, north = grid.bounds()
    assert attrs["extent_min"] == [west, south, np.nanmin(z)] and attrs["extent_max"] == [east, north, np.nanmax(z)]
    assert attrs["share_flat"] + attrs["share_general"] + attrs["share_uneven"] == pytest.approx(1.0)
    assert (attrs["source"], attrs["source_sha256"], attrs["source_format"]) == ("mem.asc", "ab" * 32, "asc")
    assert [int(t) for t in attrs["tile"]] == [16, 16] and attrs["curvature_method"] == "grid"
    assert attrs["vehicle"] == "t72"
    stored = read_attrs(path)
    for key, value in attrs.items():
        assert np.all(np.asarray(stored[key]) == np.asarray(value)), key
    assert [s[:2] for s in seen] == [(k, 12) for k in range(1, 13)] and seen[-1][2] == 45 * 52
    with h5py.File(path) as h5:
        np.testing.assert_array_equal(h5["grid/height"][()], z)
        assert h5["grid/height"].attrs["origin_x"] == X0 and h5["grid/height"].attrs["origin_y"] == grid.origin_y


def test_threads_and_tiles_do_not_change_the_store(tmp_path):
    stores = []
    for jobs, tile in ((1, 16), (2, 16), (2, (7, 100)), (1, 512)):
        path = str(tmp_path / f"g{jobs}-{tile}.h5")
        classify_dem(dem()[0], path, tile=tile, jobs=jobs)
        with h5py.File(path) as h5:
            stores.append({name: h5[name][()] for name in ("grid/height", "curvature/mean", "classes/grid",
                                                           "overview/classes", "overview/curvature")})
    for other in stores[1:]:
        for name, values in stores[0].items():
            np.testing.assert_array_equal(other[name], values, err_msg=name)


def test_the_grids_it_refuses(tmp_path):
    with pytest.raises(InputError, match="every post is NODATA"):
        classify_dem(ArrayDem(np.full((5, 6), np.nan), PostGrid(5, 6), DemSourceInfo("holes", "asc")),
                     str(tmp_path / "a.h5"))
    with pytest.raises(InputError, match="a 1 x 6 grid has no cells"):
        classify_dem(ArrayDem(np.zeros((1, 6)), PostGrid(1, 6), DemSourceInfo("line", "asc")), str(tmp_path / "b.h5"))


def test_posts_closer_than_a_micrometre_are_bad_input(tmp_path):
    """Any DEM, not only a heightmap: posts 1e-9 m apart (a unit slip) are one line, nothing written."""
    dem = ArrayDem(np.ones((5, 5)), PostGrid(5, 5, dx=1e-9, dy=1e-9), DemSourceInfo("tiny.tif", "GTiff"))
    with pytest.raises(InputError, match=r"^tiny.tif: posts 1e-09 m apart are closer than 1e-06 m"):
        classify_dem(dem, str(tmp_path / "t.h5"))
    assert not (tmp_path / "t.h5").exists()
