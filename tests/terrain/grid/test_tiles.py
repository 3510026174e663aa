"""The tile reader: windows of a store's rasters equal the arrays cut and filled past the edges,
each tile read once while its budget holds, a pickled reader carries no handle, a damaged tile
is bad input."""

import pickle

import h5py
import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.terrain.grid import store as grid_store
from tankcd_cli.terrain.grid.classify import classify_dem
from tankcd_cli.terrain.grid.sources import ArrayDem
from tankcd_cli.terrain.grid.tiles import TileReader

TILE = 16


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    """A 40 x 50 grid store in tiles of 16 posts, and its rasters."""
    path = tmp_path_factory.mktemp("tiles") / "g.h5"
    rng = np.random.default_rng(4)
    z = 10 + np.cumsum(rng.normal(0, 0.3, (40, 50)), axis=0)
    z[rng.random(z.shape) < 0.05] = np.nan
    mp = pytest.MonkeyPatch()
    mp.setattr(grid_store, "TILE", TILE)
    try:
        classify_dem(ArrayDem(z, PostGrid(40, 50, 1000.0, 2000.0)), str(path), tile=TILE)
    finally:
        mp.undo()
    with h5py.File(path) as h5:
        assert h5["grid/height"].chunks == (TILE, TILE)
        arrays = {name: h5[name][()] for name in ("grid/height", "classes/grid")}
    return str(path), arrays


def expected(array, r0, r1, c0, c1, fill):
    out = np.full((r1 - r0, c1 - c0), fill, dtype=np.result_type(array.dtype, np.asarray(fill).dtype))
    for r in range(r0, r1):
        for c in range(c0, c1):
            if 0 <= r < array.shape[0] and 0 <= c < array.shape[1]:
                out[r - r0, c - c0] = array[r, c]
    return out


WINDOWS = [(0, 40, 0, 50), (3, 19, 15, 33), (-5, 4, -2, 3), (38, 45, 47, 60), (50, 55, 0, 3), (10, 10, 0, 4)]


@pytest.mark.parametrize("window", WINDOWS)
def test_windows_are_the_arrays_cut_and_filled(stored, window):
    path, arrays = stored
    for reader in (TileReader(path=path, tile=TILE), TileReader(arrays=arrays)):
        got = reader.window("grid/height", *window, np.nan, np.float64)
        np.testing.assert_array_equal(got, expected(arrays["grid/height"], *window, np.nan))
        classes = reader.window("classes/grid", *window, 255)
        assert classes.dtype == np.uint8
        np.testing.assert_array_equal(classes, expected(arrays["classes/grid"], *window, 255))


def test_each_tile_is_read_once_while_the_budget_holds(stored):
    path, _ = stored
    tile_bytes = TILE * TILE * 8
    reader = TileReader(path=path, tile=TILE, max_bytes=3 * tile_bytes)
    reader.window("grid/height", 0, 8, 0, 8, np.nan)
    reader.window("grid/height", 2, 10, 1, 12, np.nan)  # the same tile again
    assert reader.tiles_read == 1
    reader.window("grid/height", 0, 40, 0, 50, np.nan)  # all 3 x 4 tiles: the budget keeps three
    assert reader.tiles_read == 1 + 12 - 1 and reader._bytes <= 3 * tile_bytes
    reader.window("grid/height", 0, 1, 0, 1, np.nan)  # the first tile was let go: read again
    assert reader.tiles_read == 13
    tiny = TileReader(path=path, tile=TILE, max_bytes=1)  # always keeps the newest tile
    tiny.window("grid/height", 0, 40, 0, 50, np.nan)
    assert len(tiny._cache) == 1


def test_a_pickled_reader_carries_no_handle_and_reads_the_same(stored):
    path, arrays = stored
    reader = TileReader(path=path, tile=TILE)
    before = reader.window("grid/height", 5, 30, 7, 44, np.nan)
    copy = pickle.loads(pickle.dumps(reader))
    assert copy._h5 is None and not copy._cache and copy.path == path
    np.testing.assert_array_equal(copy.window("grid/height", 5, 30, 7, 44, np.nan), before)
    reader.close()
    assert reader._h5 is None and not reader._cache


def test_a_damaged_tile_is_bad_input(stored, tmp_path):
    path, _ = stored
    damaged = tmp_path / "d.h5"
    damaged.write_bytes(open(path, "rb").read())
    with h5py.File(damaged) as h5:
        offset = h5["grid/height"].id.get_chunk_info_by_coord((TILE, 0)).byte_offset
    data = bytearray(damaged.read_bytes())
    data[offset + 100:offset + 108] = b"\xff" * 8
    damaged.write_bytes(bytes(data))
    reader = TileReader(path=str(damaged), tile=TILE)
    reader.window("grid/height", 0, TILE, 0, TILE, np.nan)  # another tile reads
    with pytest.raises(InputError, match=r"damaged tankcd terrain store: grid/height tile \(1, 0\)"):
        reader.window("grid/height", TILE, 2 * TILE, 0, 5, np.nan)
