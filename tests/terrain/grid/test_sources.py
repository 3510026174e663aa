"""DEM sources: windows read past any edge as NaN, an ESRI grid through our parser row 0 north with
its geometry and digest, each kind opened as it should be (and a store's heights read back),
and the heights no terrain has refused where they are."""

import hashlib

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.dem_source import DemSourceInfo
from tankcd_cli.terrain.grid import sources
from tankcd_cli.terrain.grid.classify import classify_dem
from tankcd_cli.terrain.grid.sources import ArrayDem, StoreDem, ascii_dem, checked_read, open_source
from tests.conftest import write_asc


def test_an_array_dem_reads_windows_past_any_edge():
    z = np.arange(12.0).reshape(3, 4)
    dem = ArrayDem(z)
    assert dem.grid == PostGrid(3, 4) and dem.info.source == "<array>"
    np.testing.assert_array_equal(dem.read(0, 3, 0, 4), z)
    w = dem.read(-1, 2, 2, 6)
    assert w.shape == (3, 4) and np.isnan(w[0]).all() and np.isnan(w[:, 2:]).all()
    np.testing.assert_array_equal(w[1:, :2], z[:2, 2:])
    assert np.isnan(dem.read(5, 7, 0, 2)).all() and dem.read(1, 1, 0, 3).shape == (0, 3)


def test_an_esri_grid_through_our_parser(tmp_path):
    z = [[7, 8, 9], [4, 5, 6], [1, 2, -9999]]  # north row first, as the file lists them
    path = write_asc(tmp_path / "g.asc", z, cellsize=2.0, xll=100.0, yll=200.0, nodata=-9999)
    with ascii_dem(str(path)) as dem:
        np.testing.assert_array_equal(dem.heights, [[7, 8, 9], [4, 5, 6], [1, 2, np.nan]])
        assert dem.grid.origin == (100.0, 204.0) and dem.grid.south_west == (100.0, 200.0)
        assert dem.grid.spacing == (2.0, 2.0) and dem.grid.crs_wkt == ""
        assert dem.info.source == str(path) and dem.info.format == "asc"
        assert dem.info.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()


def test_each_kind_opens_as_it_should(tmp_path, monkeypatch):
    rng = np.random.default_rng(1)
    z = 50 + np.cumsum(rng.normal(0, 0.2, (30, 40)), axis=1)
    asc = write_asc(tmp_path / "g.asc", z, xll=500_000.0, yll=4_200_000.0)
    own = open_source("esri_ascii", str(asc))
    assert isinstance(own, ArrayDem)
    monkeypatch.setattr(sources, "ASC_OWN_MAX_BYTES", 0)  # larger grids go through GDAL
    with open_source("esri_ascii", str(asc)) as gdal:
        assert not isinstance(gdal, ArrayDem) and gdal.grid.origin == own.grid.origin
        assert gdal.grid.spacing == own.grid.spacing
        np.testing.assert_array_equal(gdal.read(-2, 32, -1, 41), own.read(-2, 32, -1, 41))
    store = tmp_path / "g.h5"
    classify_dem(own, str(store))
    with open_source("grid_store", str(store)) as again:
        assert isinstance(again, StoreDem)
        assert again.grid.origin == own.grid.origin and (again.grid.rows, again.grid.cols) == (30, 40)
        assert again.info.source == str(asc) and again.info.sha256 == own.info.sha256
        assert again.info.height_dtype == "float64"
        np.testing.assert_array_equal(again.read(-1, 31, 3, 45), own.read(-1, 31, 3, 45))
    with pytest.raises(InputError, match="--crs applies to rasters"):
        open_source("grid_store", str(store), crs="EPSG:32633")
    with pytest.raises(ValueError, match="not a DEM kind"):
        open_source("mesh", str(asc))


def test_checked_read_refuses_heights_no_terrain_has():
    z = np.zeros((4, 5))
    z[1, 2] = 2e9
    dem = ArrayDem(z, PostGrid(4, 5), DemSourceInfo("mem", "asc"))
    np.testing.assert_array_equal(checked_read(dem, 2, 4, 0, 5), z[2:])
    with pytest.raises(InputError) as err:
        checked_read(dem, 1, 3, 1, 4)
    assert str(err.value).startswith("mem: row 2 column 3: height beyond 1e+09 m: ") and "2000000000.0" in str(err.value)
