"""Windows of a grid store's rasters, read tile by tile through a bounded cache.

A grid store keeps its rasters chunked in square tiles (docs/formats.md). A
:class:`TileReader` reads whole tiles (one HDF5 chunk each: a single read,
no partial-chunk work) and keeps the most recently used ones up to a byte
budget; a window is assembled from the tiles it overlaps. Memory is the
budget plus the window asked for, whatever the store's size.

The HDF5 file is opened on first use and again after a fork (an HDF5 handle
must not cross one), so forked fleet workers each read through their own.
"""

from __future__ import annotations

import os
from collections import OrderedDict

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.terrain.store import open_store

DEFAULT_CACHE_BYTES = 64 << 20  # tiles kept per reader; a replay's footprints touch a few dozen at most


class TileReader:
    """Windows of 2-D datasets, north row first, from a store file or from arrays in memory.

    path : a grid store (HDF5) whose datasets are chunked in ``tile`` squares, or None
    arrays : {name: 2-D array} held in memory instead of a file
    max_bytes : the cache budget
    """

    def __init__(self, path: str | None = None, arrays: dict | None = None, tile: int = 256,
                 max_bytes: int = DEFAULT_CACHE_BYTES):
        self.path = path
        self.arrays = arrays
        self.tile = int(tile)
        self.max_bytes = int(max_bytes)
        self._cache: OrderedDict = OrderedDict()
        self._bytes = 0
        self._h5 = None
        self._pid = None
        self.tiles_read = 0

    def _dataset(self, name: str):
        if self.arrays is not None:
            return self.arrays[name]
        if self._h5 is None or self._pid != os.getpid():
            # HDF5's own chunk cache off: whole tiles are read once into ours
            self._h5 = open_store(self.path, rdcc_nbytes=0)
            self._pid = os.getpid()
        return self._h5[name]

    def shape(self, name: str) -> tuple[int, int]:
        return tuple(int(s) for s in self._dataset(name).shape)

    def close(self) -> None:
        if self._h5 is not None and self._pid == os.getpid():
            self._h5.close()
        self._h5 = None
        self._cache.clear()
        self._bytes = 0

    def _tile(self, name: str, tr: int, tc: int) -> np.ndarray:
        key = (name, tr, tc)
        hit = self._cache.get(key)
        if hit is not None:
            self._cache.move_to_end(key)
            return hit
        ds = self._dataset(name)
        rows, cols = ds.shape
        t = self.tile
        try:
            block = np.asarray(ds[tr * t:min((tr + 1) * t, rows), tc * t:min((tc + 1) * t, cols)])
        except (OSError, RuntimeError, ValueError) as exc:  # a damaged chunk: bad input, not a bug
            first = str(exc).splitlines()[0][:160] if str(exc) else type(exc).__name__
            raise InputError(self.path, f"damaged tankcd terrain store: {name} tile ({tr}, {tc}): {first}") from None
        self.tiles_read += 1
        self._cache[key] = block
        self._bytes += block.nbytes
        while self._bytes > self.max_bytes and len(self._cache) > 1:
            _, old = self._cache.popitem(last=False)
            self._bytes -= old.nbytes
        return block

    def window(self, name: str, r0: int, r1: int, c0: int, c1: int, fill, dtype=None) -> np.ndarray:
        """Rows r0..r1-1 (from the north) and columns c0..c1-1 of dataset ``name``; ``fill``
        where the window reaches past the raster."""
        ds = self._dataset(name)
        rows, cols = ds.shape
        out = np.full((max(r1 - r0, 0), max(c1 - c0, 0)), fill, dtype=dtype or ds.dtype)
        lo_r, hi_r, lo_c, hi_c = max(r0, 0), min(r1, rows), max(c0, 0), min(c1, cols)
        if lo_r >= hi_r or lo_c >= hi_c:
            return out
        if self.arrays is not None:
            out[lo_r - r0:hi_r - r0, lo_c - c0:hi_c - c0] = ds[lo_r:hi_r, lo_c:hi_c]
            return out
        t = self.tile
        for tr in range(lo_r // t, (hi_r - 1) // t + 1):
            for tc in range(lo_c // t, (hi_c - 1) // t + 1):
                block = self._tile(name, tr, tc)
                br0, bc0 = tr * t, tc * t
                a_r, b_r = max(lo_r, br0), min(hi_r, br0 + block.shape[0])
                a_c, b_c = max(lo_c, bc0), min(hi_c, bc0 + block.shape[1])
                out[a_r - r0:b_r - r0, a_c - c0:b_c - c0] = block[a_r - br0:b_r - br0, a_c - bc0:b_c - bc0]
        return out

    def __getstate__(self):  # pickled for a Dask worker: the description, never the handle or tiles
        state = self.__dict__.copy()
        state.update(_h5=None, _pid=None, _cache=OrderedDict(), _bytes=0)
        return state
