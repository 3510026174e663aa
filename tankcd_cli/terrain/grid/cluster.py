"""Classify a DEM's tiles on a Dask cluster: ``tankcd classify DEM --scheduler ADDRESS``.

Each tile is one task described by a few values (the DEM's path and reading
options, the tile's rows and columns, the settings); a worker opens the DEM
itself, once per process, and reads only the tile's window with its halo. The
client gathers the results in tile order and writes the store, so the store
holds what a local run writes. A task is a pure function of its description:
when a worker is lost, Dask runs its tiles again elsewhere.
"""

from __future__ import annotations

import os
import threading
import time
from typing import Callable

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.terrain.grid.sources import checked_read, open_source
from tankcd_cli.terrain.grid.tiled_classify import classify_fetched, fetch_tile, tile_plan, tiles_of, use_compiled
from tankcd_cli.terrain.regions import Thresholds

_SOURCES: dict = {}  # spec -> opened DEM source, one per worker process
_LOCK = threading.Lock()


def _source(spec: tuple):
    with _LOCK:
        if spec not in _SOURCES:
            kind, path, fmt, band, crs, heightmap = spec
            _SOURCES.clear()  # one DEM at a time per worker
            _SOURCES[spec] = open_source(kind, path, fmt=fmt, band=band, crs=crs, heightmap=heightmap)
        return _SOURCES[spec]


def tile_task(spec: tuple, core: tuple, grid: PostGrid, method: str, track_length: float, thresholds: Thresholds,
              smoothing=None):
    """Classify one tile on a worker (see ``tiled_classify.classify_tile``)."""
    plan = tile_plan(grid, track_length, thresholds, smoothing)
    source = _source(spec)
    with _LOCK:  # one reader per DEM handle
        fetched = fetch_tile(lambda r0, r1, c0, c1: checked_read(source, r0, r1, c0, c1), plan, core)
    return classify_fetched(plan, core, fetched, method, thresholds, use_compiled(grid))


def classify_tiles_on_dask(scheduler: str, spec: tuple, grid: PostGrid, method: str, track_length: float,
                           thresholds: Thresholds,
                           tile, on_tile: Callable, progress: Callable | None = None, smoothing=None) -> None:
    """Run every tile as a task on the cluster at ``scheduler``; ``on_tile`` gets the results in
    row-major tile order (a result that arrives early waits on the cluster, not here)."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError(scheduler, "--scheduler needs Dask: pip install 'tankcd[dask]'") from None
    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise InputError(scheduler, f"cannot reach the Dask scheduler: {exc}") from None
    cores = list(tiles_of(grid, tile))
    stamp = time.time_ns()
    with client:
        futures = client.map(tile_task, [spec] * len(cores), cores, [grid] * len(cores),
                             [method] * len(cores), [track_length] * len(cores), [thresholds] * len(cores),
                             [smoothing] * len(cores), pure=False, retries=2,
                             key=[f"tankcd-tile-{os.getpid()}-{stamp}-{k}" for k in range(len(cores))])
        posts = 0
        for k, fut in enumerate(futures):
            result = fut.result()
            fut.release()
            on_tile(result)
            posts += result.height.size
            if progress:
                progress(k + 1, len(cores), posts)
