"""Height, slope, region classes and the exact footprint on a DEM held as posts.

A :class:`GridSurface` answers the same questions (``terrain.surface.Surface``) as the mesh
layout's :class:`~tankcd_cli.terrain.mesh.surface.MeshSurface`, on the grid layout's
implicit surface (each cell split along its SW-NE diagonal; a cell with three
valid posts carries the triangle of those three), with no vertex, face or
plane arrays: every query is arithmetic on posts.

Queries never load the grid. A query's points are read through one window
(the blocks of ``BLOCK`` x ``BLOCK`` posts they fall in, plus a margin wide
enough for what the query reaches: a key point, a footprint, a hull) when
that window stays under ``WINDOW_POSTS``, as a trajectory chunk's does; else
the points are grouped by block, a window each. Windows are assembled from
the store's tiles through a bounded cache and kept in a small LRU. Start-up
and memory depend on the work asked for, not on the size of the terrain.

Local coordinates: x, y relative to the grid's south-west post, so UTM
coordinates lose nothing; post (row from the south i, column c) lies at
(c dx, i dy). Kernels compute cell indices in the whole grid's indices (see
``post_queries``): a result does not depend on the window it came through.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.terrain.footprint import PostGround, footprint_batch
from tankcd_cli.terrain.grid.post_queries import (
    grid_heights_at_offsets,
    grid_heights_slopes,
    grid_highest_above_plane_bound,
    grid_plane_slab,
    grid_worst_class,
)
from tankcd_cli.terrain.grid.tiles import TileReader
from tankcd_cli.terrain.patches import PatchQueries
from tankcd_cli.terrain.regions import NO_CLASS, UNEVEN

BLOCK = 512  # posts per window side before margins
WINDOW_POSTS = 4_000_000  # a query whose points all fit one window this large reads one (32 MB of heights)
WINDOW_BYTES = 64 << 20  # assembled windows kept, at most (the newest always)


class GridSurface(PatchQueries):
    """A DEM's surface read by window.

    tiles : a :class:`~tankcd_cli.terrain.grid.tiles.TileReader` over ``grid/height`` and ``classes/grid``
    grid : the :class:`~tankcd_cli.geometry.post_grid.PostGrid` of the posts; ``rows``, ``cols``,
        ``origin_nw`` (2,) (the north-west post), ``spacing`` (2,) and ``crs`` (WKT) repeat it
        as the kernels take it
    """

    def __init__(self, tiles, grid: PostGrid):
        self.tiles = tiles
        self.grid = grid
        self.rows, self.cols = int(grid.rows), int(grid.cols)
        self.spacing = np.asarray(grid.spacing, dtype=float)
        self.origin_nw = np.asarray(grid.origin, dtype=float)
        # local origin: the south-west post
        self.origin = np.array([self.origin_nw[0], self.origin_nw[1] - (self.rows - 1) * self.spacing[1]])
        self.post_origin = np.zeros(2)
        self.crs = grid.crs_wkt
        self._windows: OrderedDict = OrderedDict()

    # --- construction -----------------------------------------------------------------

    @classmethod
    def from_arrays(cls, height: np.ndarray, classes: np.ndarray, grid: PostGrid) -> "GridSurface":
        """From rasters (rows, cols) in memory (row 0 north; NaN / 255 at NODATA) over ``grid``;
        a store's surface: ``grid.store.open_grid``."""
        if np.shape(height) != (grid.rows, grid.cols) or np.shape(classes) != (grid.rows, grid.cols):
            raise ValueError(f"rasters {np.shape(height)} and {np.shape(classes)} for a {grid.rows} x {grid.cols} grid")
        tiles = TileReader(arrays={"grid/height": height, "classes/grid": classes})
        return cls(tiles, grid)

    # --- geometry ---------------------------------------------------------------------

    def to_local(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(x, dtype=float) - self.origin[0], np.asarray(y, dtype=float) - self.origin[1]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of the south-west and north-east posts."""
        lo = self.origin.copy()
        return lo, lo + self.spacing * [self.cols - 1, self.rows - 1]

    # --- windows ----------------------------------------------------------------------

    def _margin(self, reach: float) -> int:
        """Posts a window extends past its block for queries reaching ``reach`` m from their point."""
        m = int(math.ceil(max(reach, 0.0) / float(self.spacing.min()))) + 2
        return ((m + 15) // 16) * 16  # a few sizes only, so that windows are reused across queries

    def _window(self, blocks: tuple, margin: int, classes: bool):
        """(array south row first, r_off, c_off) over blocks (br0, br1, bc0, bc1) (south-based,
        inclusive) with ``margin`` posts around them."""
        key = (blocks, margin, classes)
        hit = self._windows.get(key)
        if hit is not None:
            self._windows.move_to_end(key)
            return hit
        br0, br1, bc0, bc1 = blocks
        s0, s1 = br0 * BLOCK - margin, (br1 + 1) * BLOCK + margin + 1
        c0, c1 = bc0 * BLOCK - margin, (bc1 + 1) * BLOCK + margin + 1
        s0, s1 = max(s0, 0), min(s1, self.rows)
        c0, c1 = max(c0, 0), min(c1, self.cols)
        n0, n1 = self.rows - s1, self.rows - s0  # north-based rows of the same posts
        if classes:
            arr = self.tiles.window("classes/grid", n0, n1, c0, c1, NO_CLASS, np.uint8)
        else:
            arr = self.tiles.window("grid/height", n0, n1, c0, c1, np.nan, np.float64)
        win = (np.ascontiguousarray(arr[::-1]), s0, c0)
        self._windows[key] = win
        while len(self._windows) > 1 and sum(w[0].nbytes for w in self._windows.values()) > WINDOW_BYTES:
            self._windows.popitem(last=False)
        return win

    def _groups(self, lx: np.ndarray, ly: np.ndarray, margin: int):
        """The points grouped by window: [(indices or slice(None), (br0, br1, bc0, bc1))].

        All points in one window when their blocks' span (with margins) stays under
        WINDOW_POSTS posts (a chunk of a trajectory, a small terrain); else one window per block.
        """
        if len(lx) == 0:
            return []
        nbr = max((self.rows - 1) // BLOCK, 0)
        nbc = max((self.cols - 1) // BLOCK, 0)
        # the blocks' span from the extremes alone (most queries fit one window: no per-point work)
        r0, r1 = _block_span(ly, BLOCK * self.spacing[1], nbr)
        c0, c1 = _block_span(lx, BLOCK * self.spacing[0], nbc)
        span = ((r1 - r0 + 1) * BLOCK + 2 * margin) * ((c1 - c0 + 1) * BLOCK + 2 * margin)
        if span <= WINDOW_POSTS or (r0 == r1 and c0 == c1):
            return [(slice(None), (r0, r1, c0, c1))]
        with np.errstate(invalid="ignore"):
            bc = np.floor(lx / (BLOCK * self.spacing[0]))
            br = np.floor(ly / (BLOCK * self.spacing[1]))
        bc = np.clip(np.nan_to_num(bc, nan=0.0), 0, nbc).astype(np.int64)
        br = np.clip(np.nan_to_num(br, nan=0.0), 0, nbr).astype(np.int64)
        key = (br * (nbc + 1) + bc).astype(np.uint32 if (nbr + 1) * (nbc + 1) < 2**32 else np.int64)
        order = np.argsort(key, kind="stable")  # a radix sort for small integer keys
        cut = np.flatnonzero(np.diff(key[order])) + 1
        out = []
        for g in np.split(order, cut):
            b_r, b_c = int(br[g[0]]), int(bc[g[0]])
            out.append((g, (b_r, b_r, b_c, b_c)))
        return out

    # --- queries ----------------------------------------------------------------------

    def height_slope(self, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Height (N,) m and gradient dz/dx, dz/dy (N,) at world points; NaN off the terrain."""
        lx, ly = self.to_local(x, y)
        shape = np.shape(lx)
        lx, ly = np.ravel(lx), np.ravel(ly)
        z, gx, gy = (np.full(len(lx), np.nan) for _ in range(3))
        margin = self._margin(0.0)
        for idx, blocks in self._groups(lx, ly, margin):
            win, r_off, c_off = self._window(blocks, margin, False)
            z[idx], gx[idx], gy[idx] = grid_heights_slopes(lx[idx], ly[idx], win, self.post_origin, self.spacing,
                                                           r_off, c_off, self.rows, self.cols)
        return z.reshape(shape), gx.reshape(shape), gy.reshape(shape)

    def heights_at(self, x, y, yaw, points) -> np.ndarray:
        """Ground heights (N, k) m at points (k, 2) in each pose's heading frame; NaN off the
        terrain (``height_slope`` at those points, by one kernel that does not form them)."""
        lx, ly = self.to_local(x, y)
        lx, ly = np.ravel(lx), np.ravel(ly)
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        out = np.full((len(lx), len(points)), np.nan)
        if len(lx) == 0 or len(points) == 0:
            return out
        yaw = np.broadcast_to(np.asarray(yaw, dtype=float), lx.shape)
        su, sv = np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1])
        margin = self._margin(_reach(points))
        for idx, blocks in self._groups(lx, ly, margin):
            win, r_off, c_off = self._window(blocks, margin, False)
            out[idx] = grid_heights_at_offsets(lx[idx], ly[idx], np.ascontiguousarray(yaw[idx]), su, sv, win,
                                               self.post_origin, self.spacing, r_off, c_off, self.rows, self.cols)
        return out

    def height_normal(self, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Height (N,) m, unit upward normal (N, 3) and on-terrain mask (N,) at world points."""
        z, gx, gy = self.height_slope(x, y)
        n = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        return z, n, np.isfinite(z)

    def region_under(self, x, y, yaw, length: float, width: float) -> np.ndarray:
        """The worst region class under each footprint rectangle (N,) uint8; 255 where none is known.

        The rectangle (length along the heading, width across, centred on x, y) is
        sampled at the post spacing, corners included; each sample takes its nearest post's class.
        """
        step = float(self.spacing.min())
        nu = max(2, int(np.ceil(length / step)) + 1)
        nv = max(2, int(np.ceil(width / step)) + 1)
        su, sv = np.meshgrid(np.linspace(-length / 2, length / 2, nu), np.linspace(-width / 2, width / 2, nv))
        su, sv = su.ravel(), sv.ravel()
        lx, ly = self.to_local(x, y)
        lx, ly = np.ravel(lx), np.ravel(ly)
        yaw = np.broadcast_to(np.asarray(yaw, dtype=float), lx.shape).ravel()
        out = np.full(len(lx), NO_CLASS, dtype=np.uint8)
        margin = self._margin(math.hypot(length, width) / 2)
        for idx, blocks in self._groups(lx, ly, margin):
            win, r_off, c_off = self._window(blocks, margin, True)
            out[idx] = grid_worst_class(lx[idx], ly[idx], np.ascontiguousarray(yaw[idx]), su, sv, win,
                                        self.post_origin, self.spacing, r_off, c_off, UNEVEN)
        return out

    def highest_above_plane_bound(self, x, y, yaw, quads: np.ndarray, planes: np.ndarray) -> np.ndarray:
        """An upper bound (N,) m of how far the ground rises above each pose's plane over its
        polygons ``quads`` (N, ..., 2) in the heading frame (planes (N, 3): a + b u + c v); -inf
        where no ground is under them. Costs a pass over the posts of their bounding box, a
        fraction of the exact footprint pass: poses it clears need no exact pass."""
        lx, ly = self.to_local(x, y)
        lx, ly = np.ravel(lx), np.ravel(ly)
        n = len(lx)
        out = np.full(n, -np.inf)
        if n == 0:
            return out
        quads = np.asarray(quads, dtype=float).reshape(n, -1, 2)
        margin = self._margin(_reach(quads))
        yaw = np.broadcast_to(np.asarray(yaw, dtype=float), lx.shape)
        for idx, blocks in self._groups(lx, ly, margin):
            win, r_off, c_off = self._window(blocks, margin, False)
            out[idx] = grid_highest_above_plane_bound(lx[idx], ly[idx], yaw[idx], quads[idx], planes[idx], win,
                                                      self.post_origin, self.spacing, r_off, c_off,
                                                      self.rows, self.cols)
        return out

    def plane_slab(self, x, y, yaw, quads: np.ndarray, planes: np.ndarray,
                   limit: float = math.inf) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the ground about each pose's plane over its polygons ``quads`` (N or 1, ..., 2)
        (heading frame; planes (N, 3): a + b u + c v): (lo, hi) (N,) m, lo <= ground - plane <= hi
        everywhere over their bounding box; NaN where the box is not wholly over valid posts, or
        the slab is wider than ``limit`` m.
        A pass over the posts of the box (``grid_plane_slab``), no clipping: what the gates of
        ``matching.match`` prove their skips from."""
        lx, ly = self.to_local(x, y)
        lx, ly = np.ravel(lx), np.ravel(ly)
        n = len(lx)
        lo, hi = np.full(n, np.nan), np.full(n, np.nan)
        if n == 0:
            return lo, hi
        quads = np.asarray(quads, dtype=float)
        quads = quads.reshape(len(quads), -1, 2)
        margin = self._margin(_reach(quads))
        yaw = np.broadcast_to(np.asarray(yaw, dtype=float), lx.shape)
        for idx, blocks in self._groups(lx, ly, margin):
            win, r_off, c_off = self._window(blocks, margin, False)
            lo[idx], hi[idx] = grid_plane_slab(lx[idx], ly[idx], yaw[idx], quads if len(quads) == 1 else quads[idx],
                                               planes[idx], win, self.post_origin, self.spacing, r_off, c_off,
                                               self.rows, self.cols, limit)
        return lo, hi

    def footprint(self, mode: int, x, y, yaw, quads: np.ndarray, planes_in: np.ndarray, eps: float,
                  arithmetic: bool = True, warm: bool = False):
        """The exact footprint pass (see ``terrain.footprint.footprint_batch``) on the posts."""
        lx, ly = self.to_local(x, y)
        n = len(lx)
        out = np.full((n, 4 if mode == 2 else 3), np.nan)
        covered = np.zeros(n)
        status = np.zeros(n, dtype=np.int64)
        if n == 0:
            return out, covered, status
        margin = self._margin(_reach(quads))
        for idx, blocks in self._groups(lx, ly, margin):
            win, r_off, c_off = self._window(blocks, margin, False)
            out[idx], covered[idx], status[idx] = footprint_batch(
                mode, lx[idx], ly[idx], np.ascontiguousarray(yaw[idx]), np.ascontiguousarray(quads[idx]),
                np.ascontiguousarray(planes_in[idx]), eps, None,
                PostGround(win, self.post_origin, self.spacing, r_off, c_off), arithmetic, warm)
        return out, covered, status


def _block_span(v: np.ndarray, size: float, last: int) -> tuple[int, int]:
    """First and last block (of ``size`` m, clipped to 0..last) of local coordinates ``v``; a NaN
    coordinate counts as block 0, as in the per-point grouping."""
    lo, hi = float(np.fmin.reduce(v)), float(np.fmax.reduce(v))  # NaN only if every value is NaN
    ends = [] if math.isnan(lo) else [lo, hi]
    blocks = [min(max(math.floor(e / size) if math.isfinite(e) else (0 if e < 0 else last), 0), last) for e in ends]
    if math.isnan(float(np.min(v))):
        blocks.append(0)
    return min(blocks), max(blocks)


def _reach(quads: np.ndarray) -> float:
    """How far (m) the corners (..., 2) reach from their pose's centre."""
    if quads.size == 0:
        return 0.0
    return math.sqrt(float(np.max(quads[..., 0] ** 2 + quads[..., 1] ** 2)))
