"""Height and upward normal anywhere on a mesh-layout terrain, in one vectorized call.

A :class:`MeshSurface` is built once from a mesh-layout store (``mesh/store.py``). Points are
located in a uniform grid of cells that lists the triangles overlapping each
cell: for a DEM the cells are the DEM's own cells (two triangles each, found
by arithmetic: O(1) per point); for an irregular mesh they are the store's
triangle buckets. Heights are exact on the terrain's own triangles (the
triangle's plane, i.e. barycentric interpolation). A point over no triangle is
off the terrain: it is reported in the ``on`` mask and its height is NaN.

All arithmetic runs in local coordinates (relative to the terrain's south-west
corner), so UTM coordinates lose nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.terrain.footprint import MeshGround, PostGround, footprint_batch
from tankcd_cli.terrain.grid.post_queries import grid_worst_class
from tankcd_cli.terrain.mesh.point_queries import heights_slopes, highest_above, locate_faces
from tankcd_cli.terrain.patches import PatchQueries


@dataclass(frozen=True)
class MeshSurface(PatchQueries):
    """Arrays for point location and heights (all in local x, y; z absolute).

    origin : (2,) world x, y of the local origin, m
    vertices : (n, 3) local x, y and absolute z, m
    faces : (m, 3) int64
    plane : (m, 3) z = plane[0] + plane[1] x + plane[2] y over each face (local x, y)
    cell_origin, cell_size : (2,) lower-left corner and size of the locator cells, local, m
    cell_start, cell_face : CSR lists of the faces overlapping each cell (row-major, (ny, nx))
    cell_shape : (ny, nx)
    class_raster, class_origin, class_cell : region classes per raster cell (255: none), local origin
    post_z, post_origin, post_size : a DEM's post heights (rows, cols; NaN NODATA), local; empty for meshes
    """

    origin: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    plane: np.ndarray
    cell_origin: np.ndarray
    cell_size: np.ndarray
    cell_shape: tuple
    cell_start: np.ndarray
    cell_face: np.ndarray
    class_raster: np.ndarray
    class_origin: np.ndarray
    class_cell: float
    post_z: np.ndarray
    post_origin: np.ndarray
    post_size: np.ndarray

    @classmethod
    def from_store(cls, store) -> "MeshSurface":
        """Build from a :class:`~tankcd_cli.terrain.mesh.store.MeshStore`."""
        origin = store.vertices[:, :2].min(axis=0)
        local = np.column_stack([store.vertices[:, :2] - origin, store.vertices[:, 2]])
        faces = np.ascontiguousarray(store.faces, dtype=np.int64)
        plane = face_planes(local, faces)
        post_z = np.empty((0, 0))
        post_origin = np.zeros(2)
        post_size = np.ones(2)
        if store.grid is not None:
            cell_origin, cell_size, shape, start, cell_face = _grid_cells(store.grid, faces, len(local))
            cell_origin = cell_origin - origin
            post = store.grid.vertex[::-1]  # the kernels take the posts south row first
            post_z = np.where(post >= 0, local[np.maximum(post, 0), 2], np.nan)
            post_origin, post_size = cell_origin, cell_size
        else:
            b = store.buckets
            cell_origin = np.asarray(b.origin, dtype=float) - origin
            cell_size = np.array([b.cell, b.cell], dtype=float)
            shape, start, cell_face = tuple(b.shape), b.start, b.face.astype(np.int64)
        return cls(origin, local, faces, plane, cell_origin, cell_size, shape, np.ascontiguousarray(start, dtype=np.int64),
                   np.ascontiguousarray(cell_face, dtype=np.int64), store.class_raster,
                   np.asarray(store.raster_origin, dtype=float) - origin, float(store.raster_cell),
                   post_z, post_origin, post_size)

    def to_local(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(x, dtype=float) - self.origin[0], np.asarray(y, dtype=float) - self.origin[1]

    def locate(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Face under each world point (N,), -1 where off the terrain (the highest face on overhangs)."""
        lx, ly = self.to_local(x, y)
        return locate_faces(np.ravel(lx), np.ravel(ly), self.vertices, self.faces, self.plane, self.cell_origin,
                            self.cell_size, self.cell_shape[0], self.cell_shape[1], self.cell_start,
                            self.cell_face).reshape(np.shape(lx))

    def height_slope(self, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Height (N,) m and gradient dz/dx, dz/dy (N,) at world points; NaN off the terrain."""
        lx, ly = self.to_local(x, y)
        shape = np.shape(lx)
        z, gx, gy = heights_slopes(np.ravel(lx), np.ravel(ly), self.post_z, self.post_origin, self.post_size,
                                   self.vertices, self.faces, self.plane, self.cell_origin, self.cell_size,
                                   self.cell_shape[0], self.cell_shape[1], self.cell_start, self.cell_face)
        return z.reshape(shape), gx.reshape(shape), gy.reshape(shape)

    def ground_above(self, rotation: np.ndarray, position: np.ndarray, points: np.ndarray) -> np.ndarray:
        """How far the ground rises above body points (k, 3) placed at poses (rotation (N, 3, 3),
        world position (N, 3)), m (N,): the largest ground - z over the points on terrain (-inf if none)."""
        local = np.asarray(position, dtype=float) - [self.origin[0], self.origin[1], 0.0]
        return highest_above(np.ascontiguousarray(rotation, dtype=float), np.ascontiguousarray(local),
                             np.ascontiguousarray(points, dtype=float), self.post_z, self.post_origin, self.post_size,
                             self.vertices, self.faces, self.plane, self.cell_origin, self.cell_size,
                             self.cell_shape[0], self.cell_shape[1], self.cell_start, self.cell_face)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of the south-west and north-east corners of the terrain's extent."""
        lo = self.vertices[:, :2].min(axis=0) + self.origin
        hi = self.vertices[:, :2].max(axis=0) + self.origin
        return lo, hi

    def highest_above_plane_bound(self, x, y, yaw, quads: np.ndarray, planes: np.ndarray) -> np.ndarray:
        """An upper bound (N,) of how far the ground rises above each pose's plane over its polygons:
        none is known for a mesh (+inf), so every pose takes the exact footprint pass."""
        return np.full(len(np.atleast_1d(x)), np.inf)

    def plane_slab(self, x, y, yaw, quads: np.ndarray, planes: np.ndarray,
                   limit: float = float("inf")) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the ground about each pose's plane: none is kept for a mesh yet (NaN), so no
        gate proves anything on one and every pose takes the exact passes."""
        n = len(np.atleast_1d(x))
        return np.full(n, np.nan), np.full(n, np.nan)

    def footprint(self, mode: int, x, y, yaw, quads: np.ndarray, planes_in: np.ndarray, eps: float,
                  arithmetic: bool = True, warm: bool = False):
        """The exact footprint pass (see ``terrain.footprint.footprint_batch``); ``arithmetic``
        lets full DEM cells be read from the posts (False: clip every triangle, the oracle)."""
        lx, ly = self.to_local(x, y)
        posts = self.post_ground() if arithmetic and self.post_z.size else None
        return footprint_batch(mode, lx, ly, np.ascontiguousarray(yaw, dtype=float), quads, planes_in, eps,
                               self.mesh_ground(), posts, warm=warm)

    def mesh_ground(self):
        """The faces and their locator, as the footprint pass reads them."""
        # a DEM's faces each sit in one locator cell; an irregular mesh's may span several
        return MeshGround(self.vertices, self.faces, self.plane, self.cell_origin, self.cell_size,
                          self.cell_shape[0], self.cell_shape[1], self.cell_start, self.cell_face,
                          self.post_z.size > 0)

    def post_ground(self):
        """A DEM mesh's posts, as the footprint pass reads them."""
        return PostGround(self.post_z, self.post_origin, self.post_size)

    def height_normal(self, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Height (N,) m, unit upward normal (N, 3) and on-terrain mask (N,) at world points.

        Off the terrain the height and normal are NaN and ``on`` is False.
        """
        z, gx, gy = self.height_slope(x, y)
        n = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        return z, n, np.isfinite(z)

    def region_under(self, x: np.ndarray, y: np.ndarray, yaw: np.ndarray, length: float, width: float) -> np.ndarray:
        """The worst region class under each footprint rectangle (N,) uint8; 255 where none is known.

        The rectangle (length along the heading, width across, centred on x, y)
        is sampled at the class raster's resolution, corners included.
        """
        nu = max(2, int(np.ceil(length / self.class_cell)) + 1)
        nv = max(2, int(np.ceil(width / self.class_cell)) + 1)
        su, sv = np.meshgrid(np.linspace(-length / 2, length / 2, nu), np.linspace(-width / 2, width / 2, nv))
        lx, ly = self.to_local(x, y)
        # the class raster's cells are centred on its posts: the nearest post's class, as on a grid
        yaw = np.broadcast_to(np.asarray(yaw, dtype=float), np.shape(lx))
        return grid_worst_class(np.ravel(lx), np.ravel(ly), np.ascontiguousarray(np.ravel(yaw)), su.ravel(), sv.ravel(),
                                self.class_raster, np.asarray(self.class_origin, dtype=float),
                                np.array([self.class_cell, self.class_cell]), 0, 0)


def face_planes(local: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Plane z = p0 + p1 x + p2 y of each face (m, 3); vertical faces get NaN (they hold no height)."""
    a, b, c = local[faces[:, 0]], local[faces[:, 1]], local[faces[:, 2]]
    e1, e2 = b - a, c - a
    nrm = np.cross(e1, e2)
    with np.errstate(divide="ignore", invalid="ignore"):
        p1 = -nrm[:, 0] / nrm[:, 2]
        p2 = -nrm[:, 1] / nrm[:, 2]
    vertical = ~(np.abs(nrm[:, 2]) > 1e-12 * np.maximum(np.einsum("ij,ij->i", e1, e1), np.einsum("ij,ij->i", e2, e2)))
    p1[vertical] = np.nan
    p2[vertical] = np.nan
    p0 = a[:, 2] - p1 * a[:, 0] - p2 * a[:, 1]
    return np.column_stack([p0, p1, p2])


def _grid_cells(posts, faces: np.ndarray, n: int):
    """A DEM's cells (``posts``, its PostVertices) as locator cells, south row first from its
    south-west post: each lists its one or two triangles."""
    vertex = posts.vertex[::-1]
    rows, cols = vertex.shape
    post_row = np.empty(n, dtype=np.int64)
    post_col = np.empty(n, dtype=np.int64)
    valid = vertex >= 0
    rr, cc = np.nonzero(valid)
    post_row[vertex[valid]] = rr
    post_col[vertex[valid]] = cc
    cell = post_row[faces].min(axis=1) * (cols - 1) + post_col[faces].min(axis=1)
    order = np.argsort(cell, kind="stable")
    start = np.zeros((rows - 1) * (cols - 1) + 1, dtype=np.int64)
    np.cumsum(np.bincount(cell, minlength=(rows - 1) * (cols - 1)), out=start[1:])
    g = posts.geometry
    return np.asarray(g.south_west, dtype=float), np.asarray(g.spacing, dtype=float), (rows - 1, cols - 1), start, order
