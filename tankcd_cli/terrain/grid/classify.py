"""Classify a DEM: a windowed DEM source (``sources.py``) in, a grid-layout store out, tile by tile
(``tiled_classify.py``), in this process's threads or on a Dask cluster (``cluster.py``)."""

from __future__ import annotations

import datetime
import os
import time
from typing import Callable

import numpy as np

from tankcd_cli import __version__
from tankcd_cli.errors import InputError, warn
from tankcd_cli.terrain.grid.cluster import classify_tiles_on_dask
from tankcd_cli.terrain.grid.quantum import filter_passes, find_quantum, step_hint
from tankcd_cli.terrain.grid.resolution import coarse_posts, spacing_over_track
from tankcd_cli.terrain.grid.sources import checked_read
from tankcd_cli.terrain.grid.store import GridStoreWriter
from tankcd_cli.terrain.grid.tiled_classify import DEFAULT_TILE, classify_grid_tiles, fine_posts
from tankcd_cli.terrain.regions import Thresholds, default_thresholds
from tankcd_cli.vehicle import Vehicle, vehicle_preset


def default_jobs() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def classify_dem(source, out_path: str, method: str = "grid", vehicle: Vehicle | None = None,
                 thresholds: Thresholds | None = None, tile=DEFAULT_TILE, jobs: int | None = None,
                 progress: Callable[[int, int, int, float], None] | None = None, scheduler: str | None = None,
                 spec: tuple | None = None) -> dict:
    """Classify every post of ``source`` (see ``grid.sources``) into a grid store at ``out_path``.

    progress(tiles_done, tiles_total, posts_done, seconds) after each tile.
    scheduler : a Dask scheduler's address: the tiles run there as tasks, each worker reading
        its windows of the DEM named by ``spec`` ((kind, path, format, band, crs), the arguments
        of ``sources.open_source`` with a path every worker sees); this process writes the store,
        in the same tile order as a local run.
    Returns the store's root attributes.
    """
    vehicle = vehicle or vehicle_preset("t72")
    thresholds = thresholds or default_thresholds(vehicle)
    grid, info = source.grid, source.info
    if grid.rows < 2 or grid.cols < 2:
        raise InputError(info.source, f"a {grid.rows} x {grid.cols} grid has no cells (needs at least 2 x 2 posts)")
    dx, dy = float(grid.dx), float(grid.dy)

    def read(r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        return checked_read(source, r0, r1, c0, c1)

    # set-up checks, before anything is written (--strict makes their warnings bad input)
    coarse = coarse_posts(grid, vehicle, info.source)
    stride = fine_posts(grid, vehicle, info.source)
    quantum, passes = quantized_heights(read, grid, info, thresholds)
    smoothing = (quantum.step, passes) if passes else None
    started = time.perf_counter()
    writer = GridStoreWriter(out_path, grid, info.height_dtype)

    try:
        if scheduler:
            classify_tiles_on_dask(scheduler, spec, grid, method, vehicle.track_length, thresholds, tile,
                                   writer.write, progress_of(progress, started), smoothing)
        else:
            classify_grid_tiles(read, grid, method, vehicle.track_length, thresholds, tile=tile,
                                jobs=jobs or default_jobs(), on_tile=writer.write,
                                progress=progress_of(progress, started), smoothing=smoothing)
        if writer.valid == 0:
            raise InputError(info.source, "every post is NODATA")
        total = writer.by_class.sum()
        shares = writer.by_class / total if total > 0 else writer.by_class
        nw = np.asarray(grid.origin, dtype=float)
        lo = [nw[0], nw[1] - (grid.rows - 1) * dy, writer.zmin]
        hi = [nw[0] + (grid.cols - 1) * dx, nw[1], writer.zmax]
        attrs = {
            "tankcd_version": __version__,
            "created_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "source": info.source,
            "source_sha256": info.sha256,
            "source_format": info.format,
            "source_up_axis": "z",
            "source_crs_name": info.source_crs_name or grid.crs_name,
            "reprojected": bool(info.reprojected),
            "source_crs": info.source_crs_wkt,
            "source_point_scale": float(info.source_point_scale),
            "source_point_scale_range": [float(v) for v in info.source_point_scale_range],
            "crs_name": grid.crs_name,
            "diagonal": "SW-NE",
            "rows": grid.rows, "cols": grid.cols,
            "valid_posts": writer.valid, "nodata_posts": grid.rows * grid.cols - writer.valid,
            "curvature_method": method,
            "boundary_treatment": "one-sided quartic fit over the 40 nearest valid posts (within 12 posts)",
            "threshold_flat": thresholds.flat,
            "threshold_uneven": thresholds.uneven,
            "threshold_derivation": thresholds.derivation,
            "class_average": "area-weighted mean of |H| (H first averaged over a disk of radius track_length/4) "
                             "over a disk of radius track_length/2, at every post" + (
                                 "" if stride == (1, 1) else
                                 f" of one in {stride[0]} x {stride[1]} (posts finer than track_length/100), each "
                                 "post taking the nearest one's"),
            "vehicle": vehicle.name,
            "track_length": vehicle.track_length,
            "track_width": vehicle.track_width,
            "share_flat": shares[0], "share_general": shares[1], "share_uneven": shares[2],
            "extent_min": lo, "extent_max": hi,
            "tile": list(np.broadcast_to(np.asarray(tile), 2).astype(int)),
            "height_quantum": quantum.step if quantum else 0.0,
            "height_quantum_levels": quantum.levels if quantum else 0,
            "height_quantum_sampled_posts": quantum.sampled if quantum else 0,
            "height_quantum_terraces": quantum.terraces if quantum else 0.0,
            "height_quantum_relief": quantum.relief if quantum else 0.0,
            "height_quantum_shows": bool(quantum.shows) if quantum else False,
            "quantum_filter_passes": passes,
            "quantum_filter": quantum_filter_text(passes),
            "post_spacing_over_track": spacing_over_track(dx, dy, vehicle.track_length),
            "coarse_posts": bool(coarse),
            "class_post_stride": [int(stride[0]), int(stride[1])],
            "heightmap": info.heightmap,
        }
        writer.finish(attrs)
    except BaseException:
        writer.abort()
        raise
    return attrs


def quantized_heights(read, grid, info, thresholds: Thresholds):
    """(the Quantum found on a sample of the DEM or None, smoothing passes); a SetupWarning
    naming the step when the passes are not 0 (``quantum.py``)."""
    quantum = find_quantum(read, grid.rows, grid.cols, info.height_dtype)
    if quantum is None or not quantum.shows:
        return quantum, 0
    passes = filter_passes(quantum.step, grid.dx, grid.dy, thresholds.flat)
    if passes:
        h = min(grid.dx, grid.dy)
        warn(info.source, f"heights are quantized in steps of {quantum.step:.3g} m{step_hint(quantum, info.dtype)}: "
                          f"at {h:g} m posts the classes would follow the terraces; the curvature is taken from the "
                          f"heights smoothed within half a step ({passes} passes; the store keeps the source heights)")
    return quantum, passes


def quantum_filter_text(passes: int) -> str:
    """The store's ``quantum_filter`` attribute."""
    if not passes:
        return "none"
    return (f"{passes} passes of the 3 x 3 binomial average, each height clipped to within half a step of its "
            "source height, before the curvature")


def progress_of(progress, started: float):
    if progress is None:
        return None
    return lambda done, total, posts: progress(done, total, posts, time.perf_counter() - started)
