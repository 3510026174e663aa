"""DEMs and surfaces the grid layout's tests share: random-walk ground with holes, its tiled
classification gathered into whole rasters, and the same ground as both layouts' surfaces."""

import dataclasses

import numpy as np

from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.terrain import synthetic
from tankcd_cli.terrain.grid import tiled_classify as gc
from tankcd_cli.terrain.grid.sources import ArrayDem
from tankcd_cli.terrain.mesh.classify import classify_mesh
from tankcd_cli.terrain.mesh.surface import MeshSurface
from tankcd_cli.terrain.regions import default_thresholds
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")
THRESHOLDS = default_thresholds(T72)
X0, Y0 = 500000.0, 4200000.0  # UTM-like: the south-west post


def rough_dem(rows, cols, seed=0, holes=True):
    """Random-walk heights (row 0 north) with NODATA holes, specks and a missing corner."""
    rng = np.random.default_rng(seed)
    z = 100 + np.cumsum(rng.normal(0, 0.05, (rows, cols)), axis=0) + np.cumsum(rng.normal(0, 0.05, (rows, cols)), axis=1)
    if holes:
        z[rows // 4:rows // 4 + 7, cols // 3:cols // 3 + 9] = np.nan
        z[rng.random(z.shape) < 0.01] = np.nan
        z[:3, :4] = np.nan
        z[-5:, -2:] = np.nan
    return z


def classify_arrays(z, method="grid", tile=gc.DEFAULT_TILE, jobs=1, dx=1.0, dy=1.0):
    """mean, classes (row 0 north) of a DEM by the tiled pipeline."""
    rows, cols = z.shape
    out = {k: np.full((rows, cols), np.nan) for k in ("mean", "footprint", "classes")}

    def keep(t):
        h, w = t.height.shape
        for k in out:
            out[k][t.r0:t.r0 + h, t.c0:t.c0 + w] = getattr(t, k)

    def read(r0, r1, c0, c1):
        return ArrayDem(z, None).read(r0, r1, c0, c1)

    gc.classify_grid_tiles(read, PostGrid(rows, cols, dx=dx, dy=dy), method, T72.track_length, THRESHOLDS,
                           tile=tile, jobs=jobs, on_tile=keep)
    return out


def dem_as_mesh(z):
    raw = synthetic.dem_terrain(z[::-1], origin=(X0, Y0), spacing=1.0)  # the mesh layout numbers rows from the south
    return raw


def grid_and_mesh_surfaces(z):
    """The same DEM as a GridSurface (posts only) and a mesh-layout MeshSurface, with the
    mesh's classes on both so that every matcher choice is the same."""
    from tankcd_cli.terrain.grid.surface import GridSurface

    raw = dem_as_mesh(z)
    store = classify_mesh(raw)
    classes = np.full(z.shape, 255, np.uint8)
    v = raw.grid.vertex  # row 0 north, as the grid's
    classes[v >= 0] = store.vertex_class[v[v >= 0]]
    rows = z.shape[0]
    grid = GridSurface.from_arrays(z.copy(), classes, PostGrid(rows, z.shape[1], X0, Y0 + (rows - 1) * 1.0))
    mesh = MeshSurface.from_store(store)
    # the mesh layout's class raster replaced by the posts' classes (cells centred on the posts)
    mesh = dataclasses.replace(mesh, class_raster=np.ascontiguousarray(classes[::-1]),
                               class_origin=np.array([X0, Y0]) - mesh.origin, class_cell=1.0)
    return grid, mesh


def points(z, n, seed):
    rng = np.random.default_rng(seed)
    rows, cols = z.shape
    x = X0 + rng.uniform(-4, cols + 3, n)
    y = Y0 + rng.uniform(-4, rows + 3, n)
    k = n // 10
    x[:k] = X0 + rng.integers(0, cols, k)  # exactly on posts
    y[:k] = Y0 + rng.integers(0, rows, k)
    x[k:2 * k] = X0 + rng.integers(0, cols, k) + 0.5  # on grid lines
    return x, y, rng.uniform(-np.pi, np.pi, n)
