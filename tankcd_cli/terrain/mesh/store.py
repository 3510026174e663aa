"""The terrain store's mesh layout (HDF5): what ``classify`` writes for a mesh, and replay reads.

Layout (docs/formats.md; the documented paths first, the rest makes later queries fast):

/mesh/vertices            (n, 3) float64   world coordinates, m
/mesh/faces               (m, 3) int32/64  vertex indices
/curvature/mean           (n,) float64     signed mean curvature H, 1/m
/curvature/footprint      (n,) float64     footprint-averaged |H| that the classes come from, 1/m
/classes/vertex           (n,) uint8       0 flat, 1 general, 2 uneven
/classes/raster           (ny, nx) uint8   class per raster cell (255: no terrain); attrs origin, cell
/curvature/footprint_raster (ny, nx) float32  averaged |H| per raster cell (NaN: no terrain)
/index/start, /index/face                  triangle buckets for point location on irregular meshes;
                                           attrs origin, cell, shape
/grid/vertex              (rows, cols) int64  DEMs only: vertex of each post (-1 NODATA), which
                                           locates any point in O(1); attrs origin, spacing

Datasets are stored contiguous and uncompressed so that readers can map them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import h5py
import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostGrid, PostVertices
from tankcd_cli.io.h5 import check_indices, read_errors
from tankcd_cli.terrain.mesh.locate import TriangleBuckets
from tankcd_cli.terrain.store import FORMAT, FORMAT_VERSION, WHAT, open_store, plain_value


@dataclass
class MeshStore:
    """Everything in a mesh-layout store, as arrays. ``attrs`` holds the root attributes."""

    vertices: np.ndarray
    faces: np.ndarray
    mean_curvature: np.ndarray
    footprint_curvature: np.ndarray
    vertex_class: np.ndarray
    class_raster: np.ndarray
    footprint_raster: np.ndarray
    raster_origin: np.ndarray
    raster_cell: float
    buckets: TriangleBuckets | None  # for irregular meshes
    grid: PostVertices | None  # for a DEM read as a mesh: the vertex of each post
    attrs: dict = field(default_factory=dict)


def write_mesh_store(path: str, store: MeshStore) -> None:
    """Write a store to ``path`` (callers wrap this in an atomic rename)."""
    n = len(store.vertices)
    face_dtype = np.int32 if n < 2**31 else np.int64
    with h5py.File(path, "w") as h5:
        h5.attrs["format"] = FORMAT
        h5.attrs["format_version"] = FORMAT_VERSION
        h5.attrs["layout"] = "mesh"
        for key, value in store.attrs.items():
            h5.attrs[key] = value
        h5["mesh/vertices"] = store.vertices.astype(np.float64)
        h5["mesh/faces"] = store.faces.astype(face_dtype)
        h5["curvature/mean"] = store.mean_curvature.astype(np.float64)
        h5["curvature/footprint"] = store.footprint_curvature.astype(np.float64)
        h5["curvature/footprint_raster"] = store.footprint_raster.astype(np.float32)
        h5["classes/vertex"] = store.vertex_class.astype(np.uint8)
        ds = h5.create_dataset("classes/raster", data=store.class_raster.astype(np.uint8))
        for d in (ds, h5["curvature/footprint_raster"]):
            d.attrs["origin"] = store.raster_origin
            d.attrs["cell"] = store.raster_cell
        b = store.buckets
        if b is not None:
            grp = h5.create_group("index")
            grp.attrs["kind"] = "triangle buckets"
            grp.attrs["origin"] = b.origin
            grp.attrs["cell"] = b.cell
            grp.attrs["shape"] = np.asarray(b.shape)
            grp["start"] = b.start
            grp["face"] = b.face
        if store.grid is not None:  # south row first, from the south-west post (format version 2)
            g = h5.create_dataset("grid/vertex", data=store.grid.vertex[::-1])
            g.attrs["origin"] = np.array(store.grid.geometry.south_west, dtype=float)
            g.attrs["spacing"] = np.array(store.grid.geometry.spacing, dtype=float)


def read_mesh_store(path: str) -> MeshStore:
    """Read a whole mesh-layout store into memory (a grid-layout one is an InputError)."""
    what = WHAT
    h5 = open_store(path)
    with h5, read_errors(path, what):
        # list() first: see terrain.store.read_attrs
        attrs = {k: plain_value(v) for k, v in list(h5.attrs.items())}
        if attrs.get("layout") == "grid":
            raise InputError(path, "a grid-layout store (a DEM) is read by window, not whole")
        buckets = None
        if "index" in h5:
            idx = h5["index"]
            buckets = TriangleBuckets(np.asarray(idx.attrs["origin"]), float(idx.attrs["cell"]),
                                      tuple(int(s) for s in idx.attrs["shape"]), idx["start"][()],
                                      idx["face"][()])
        grid = None
        if "grid/vertex" in h5:
            g = h5["grid/vertex"]
            south = g[()]
            (x0, y0), (dx, dy) = (np.asarray(g.attrs[k], dtype=float) for k in ("origin", "spacing"))
            grid = PostVertices(PostGrid.from_south_west(*south.shape, x0, y0, dx, dy), south[::-1])
        raster = h5["classes/raster"]
        store = MeshStore(
            vertices=h5["mesh/vertices"][()], faces=h5["mesh/faces"][()].astype(np.int64),
            mean_curvature=h5["curvature/mean"][()], footprint_curvature=h5["curvature/footprint"][()],
            vertex_class=h5["classes/vertex"][()], class_raster=raster[()],
            footprint_raster=h5["curvature/footprint_raster"][()],
            raster_origin=np.asarray(raster.attrs["origin"]), raster_cell=float(raster.attrs["cell"]),
            buckets=buckets, grid=grid, attrs=attrs)
    _check_store(path, what, store)
    return store


def _check_store(path: str, what: str, s: MeshStore) -> None:
    """Shapes and indices that the compiled kernels trust without bounds checks."""
    n = len(s.vertices)
    if s.vertices.ndim != 2 or s.vertices.shape[1] != 3 or s.faces.ndim != 2 or s.faces.shape[1] != 3:
        raise InputError(path, f"damaged {what}: mesh arrays have the wrong shape")
    if not np.isfinite(s.vertices).all():
        raise InputError(path, f"damaged {what}: non-finite vertex coordinates")
    check_indices(path, what, s.faces, n, "face")
    if s.faces.size and s.faces.min() < 0:
        raise InputError(path, f"damaged {what}: negative face indices")
    for name in ("mean_curvature", "footprint_curvature", "vertex_class"):
        if len(getattr(s, name)) != n:
            raise InputError(path, f"damaged {what}: {name} has {len(getattr(s, name))} values for {n} vertices")
    if s.class_raster.ndim != 2 or not np.isfinite(s.raster_cell) or s.raster_cell <= 0:
        raise InputError(path, f"damaged {what}: bad class raster")
    if s.buckets is not None:
        check_indices(path, what, s.buckets.face, len(s.faces), "bucket face")
        if len(s.buckets.start) != int(np.prod(s.buckets.shape)) + 1 or (np.diff(s.buckets.start) < 0).any() \
                or s.buckets.start[-1] != len(s.buckets.face) or s.buckets.start[0] != 0:
            raise InputError(path, f"damaged {what}: bad triangle buckets")
    if s.grid is not None:
        check_indices(path, what, s.grid.vertex, n, "grid post")
