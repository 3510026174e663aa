"""Tiles as Dask tasks: a task is the local pipeline's tile, a worker keeps one DEM open, and a
run on a cluster writes the store a local run writes, tile for tile."""

import h5py
import numpy as np
import pytest

from tankcd_cli.terrain.grid import cluster
from tankcd_cli.terrain.grid.classify import classify_dem
from tankcd_cli.terrain.grid.sources import open_source
from tankcd_cli.terrain.grid.tiled_classify import classify_grid_tiles
from tankcd_cli.terrain.regions import default_thresholds
from tankcd_cli.vehicle import vehicle_preset
from tests.conftest import write_asc

T72 = vehicle_preset("t72")


@pytest.fixture
def asc(tmp_path):
    rng = np.random.default_rng(7)
    z = 30 + np.cumsum(rng.normal(0, 0.3, (37, 41)), axis=0)
    return str(write_asc(tmp_path / "g.asc", z, xll=500_000.0, yll=4_200_000.0))


def test_a_task_is_the_local_tile(asc):
    spec = ("esri_ascii", asc, None, None, None, None)
    dem = open_source(*spec)
    local = []
    classify_grid_tiles(dem.read, dem.grid, "jet", T72.track_length, default_thresholds(T72), tile=16,
                        on_tile=local.append)
    for t in local[:4] + local[-1:]:
        core = (t.r0, t.r0 + t.height.shape[0], t.c0, t.c0 + t.height.shape[1])
        task = cluster.tile_task(spec, core, dem.grid, "jet", T72.track_length, default_thresholds(T72))
        for name in ("height", "mean", "footprint", "classes", "area_by_class"):
            np.testing.assert_array_equal(getattr(task, name), getattr(t, name), err_msg=name)
        assert (task.r0, task.c0, task.valid) == (t.r0, t.c0, t.valid)


def test_a_worker_keeps_one_dem_open(asc, tmp_path):
    spec = ("esri_ascii", asc, None, None, None, None)
    first = cluster._source(spec)
    assert cluster._source(spec) is first
    other = ("esri_ascii", str(write_asc(tmp_path / "h.asc", np.ones((3, 3)))), None, None, None, None)
    assert cluster._source(other) is not first and list(cluster._SOURCES) == [other]


def test_a_cluster_writes_what_a_local_run_writes(asc, tmp_path):
    distributed = pytest.importorskip("distributed")
    spec = ("esri_ascii", asc, None, None, None, None)
    local, remote = str(tmp_path / "local.h5"), str(tmp_path / "remote.h5")
    classify_dem(open_source(*spec), local, method="cotan", tile=16)
    done = []
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as dask:
        classify_dem(open_source(*spec), remote, method="cotan", tile=16, scheduler=dask.scheduler_address,
                     spec=spec, progress=lambda *a: done.append(a[:2]))
    assert done == [(k, 9) for k in range(1, 10)]  # in tile order
    with h5py.File(local) as a, h5py.File(remote) as b:
        for name in ("grid/height", "curvature/mean", "classes/grid", "overview/classes", "overview/curvature"):
            np.testing.assert_array_equal(a[name][()], b[name][()], err_msg=name)


def test_a_task_of_fine_posts_is_the_local_tile(tmp_path):
    """Posts 1 cm apart (the classes on one post in 5): a task reads and classifies as a local tile."""
    rng = np.random.default_rng(8)
    z = 30 + np.cumsum(rng.normal(0, 0.003, (33, 29)), axis=0)
    path = str(write_asc(tmp_path / "f.asc", z, cellsize=0.01, xll=500_000.0, yll=4_200_000.0))
    spec = ("esri_ascii", path, None, None, None, None)
    dem = open_source(*spec)
    local = []
    classify_grid_tiles(dem.read, dem.grid, "grid", T72.track_length, default_thresholds(T72), tile=16,
                        on_tile=local.append)
    for t in local:
        core = (t.r0, t.r0 + t.height.shape[0], t.c0, t.c0 + t.height.shape[1])
        task = cluster.tile_task(spec, core, dem.grid, "grid", T72.track_length, default_thresholds(T72))
        for name in ("height", "mean", "footprint", "classes", "area_by_class"):
            np.testing.assert_array_equal(getattr(task, name), getattr(t, name), err_msg=name)
