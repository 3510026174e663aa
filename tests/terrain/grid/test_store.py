"""The grid layout of the store: written tile by tile, read by window through a bounded cache."""

import numpy as np

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
