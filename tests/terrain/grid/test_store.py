"""The grid layout of the store: written tile by tile with its geometry and overview, read by window
through a bounded cache, refused when damaged."""

import h5py
import numpy as np
import pytest

from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.dem_source import DemSourceInfo
from tankcd_cli.terrain.grid.sources import ArrayDem
from tests.terrain.grid.dems import X0, Y0, points, rough_dem


def test_store_surface_equals_in_memory_and_cache_is_bounded(tmp_path):
    from tankcd_cli.terrain.grid.classify import classify_dem
    from tankcd_cli.terrain.grid.store import open_grid
    from tankcd_cli.terrain.grid.surface import GridSurface

    z = rough_dem(700, 650, seed=11)
    rows, cols = z.shape
    grid = PostGrid(rows, cols, X0, Y0 + rows - 1.0)
    path = str(tmp_path / "s.h5")
    classify_dem(ArrayDem(z, grid, DemSourceInfo("mem", "asc")), path, jobs=2)
    surf = open_grid(path, cache_bytes=2 << 20)
    import h5py

    with h5py.File(path) as h5:
        classes = h5["classes/grid"][()]
        np.testing.assert_array_equal(h5["grid/height"][()], z)
    mem = GridSurface.from_arrays(z, classes, grid)
    x, y, yaw = points(z, 20000, 12)
    for a, b in zip(surf.height_slope(x, y), mem.height_slope(x, y)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(surf.region_under(x, y, yaw, 4.3, 3.4), mem.region_under(x, y, yaw, 4.3, 3.4))
    assert surf.tiles._bytes <= 2 << 20  # the budget holds while the queries span the whole store
    assert surf.tiles.tiles_read > 0


def _written(tmp_path, z, grid, tile=16):
    from tankcd_cli.terrain.grid.classify import classify_dem

    path = str(tmp_path / "g.h5")
    classify_dem(ArrayDem(z, grid, DemSourceInfo("mem", "asc")), path, tile=tile)
    return path


def test_the_geometry_round_trips(tmp_path):
    from tankcd_cli.terrain.grid.store import TILE, open_grid, read_overview

    z = rough_dem(300, 280, seed=3)
    grid = PostGrid(300, 280, X0, Y0 + 299 * 0.5, 0.5, 0.5, 'PROJCS["local"]', "a local projection")
    path = _written(tmp_path, z, grid)
    assert open_grid(path).grid == grid and read_overview(path)["grid"] == grid
    with h5py.File(path) as h5:
        h = h5["grid/height"]
        assert h.chunks == (TILE, TILE) and h.fletcher32 and h5["classes/grid"].chunks == (TILE, TILE)
        assert (h.attrs["origin_x"], h.attrs["origin_y"]) == grid.origin and list(h.attrs["spacing"]) == [0.5, 0.5]
        assert h.attrs["crs"] == grid.crs_wkt and h.attrs["crs_name"] == grid.crs_name


def _overview_against_the_posts(tmp_path, monkeypatch, holes):
    from tankcd_cli.terrain.grid import store

    monkeypatch.setattr(store, "OVERVIEW_MAX", 12)  # blocks of 5 posts, cut by the 16-post tiles
    z = rough_dem(57, 44, seed=5, holes=holes) * 4
    path = _written(tmp_path, z, PostGrid(57, 44, X0, Y0 + 56.0))
    ov = store.read_overview(path)
    assert ov["step"] == 5 and ov["classes"].shape == (12, 9)
    with h5py.File(path) as h5:
        classes = h5["classes/grid"][()]
    for br in range(12):
        for bc in range(9):
            block = classes[5 * br:5 * br + 5, 5 * bc:5 * bc + 5]
            valid = block[block != 255]
            assert ov["classes"][br, bc] == (valid.max() if valid.size else 255), (br, bc)
            assert np.isfinite(ov["curvature"][br, bc]) == bool(valid.size)


def test_the_overview_is_the_worst_class_of_each_block(tmp_path, monkeypatch):
    _overview_against_the_posts(tmp_path, monkeypatch, holes=False)


@pytest.mark.xfail(strict=True, reason="GridStoreWriter._overview: np.where(valid, classes, -1) stays uint8 "
                                       "under NumPy 2 (-1 becomes 255), so a block with any NODATA post reads "
                                       "255 (no class); fixing it changes stores' overview and maps")
def test_the_overview_of_blocks_with_nodata_posts(tmp_path, monkeypatch):
    _overview_against_the_posts(tmp_path, monkeypatch, holes=True)


def test_a_damaged_geometry_is_refused(tmp_path):
    from tankcd_cli.errors import InputError
    from tankcd_cli.terrain.grid.store import open_grid

    path = _written(tmp_path, rough_dem(20, 30, seed=1), PostGrid(20, 30, X0, Y0 + 19.0))
    with h5py.File(path, "a") as h5:
        h5["grid/height"].attrs["spacing"] = [0.0, 1.0]
    with pytest.raises(InputError, match="bad grid geometry"):
        open_grid(path)
    with h5py.File(path, "a") as h5:
        h5["grid/height"].attrs["spacing"] = [1.0, 1.0]
        del h5["curvature/mean"]
        h5.create_dataset("curvature/mean", data=np.zeros((3, 3), np.float32))
    with pytest.raises(InputError, match="curvature/mean is"):
        open_grid(path)
