"""Classify a DEM tile by tile: curvature, footprint-averaged curvature and region classes.

The DEM is read window by window (a tile of ``tile`` x ``tile`` posts plus a
halo as wide as every stencil that feeds the tile's posts), so peak memory
depends on the tile, not on the DEM. Every quantity at a post is a fixed
function of the posts around it, summed in a fixed order, so the result is the
same, bit for bit, whatever the tiling: a whole raster at once is one tile.

Per post (row 0 north, NaN at NODATA; x = column dx, y = -row dy):

- **Mean curvature H**, 1/m, by ``method``:
  ``grid`` (the default for DEMs) central differences over the 3 x 3 posts
  around it, put in the formula of docs/formats.md (second order, as GIS tools do it);
  ``cotan``, ``sphere``, ``jet`` the mesh estimators (``terrain/curvature/``) on the
  implicit triangulation, exactly as the mesh layout computes them.
  Posts without the neighbours a formula needs (the DEM's edges, NODATA
  borders; ``open_posts``) get the one-sided treatment the mesh layout gives
  its boundary: a least-squares quartic over the ``BOUNDARY_NEIGHBOURS`` (40)
  nearest valid posts, here looked for within ``FIT_RADIUS`` posts (a speck of
  fewer than 14 valid posts there has H = 0).
- **Post area** a, m^2: a third of the 3-D area of each triangle at the post.
- **Footprint-averaged |H|** (the value the classes come from; see
  ``regions.py``): H averaged (area-weighted) over a disk of radius L/4, then
  its absolute value averaged over a disk of radius L/2, both disks in metres
  over the posts (L the track length).
- **Class** 0 flat, 1 general, 2 uneven; 255 at NODATA.

**Posts finer than a track feels.** The disks are in metres, so their posts grow as the
square of track length over spacing: at 1 cm posts a T-72's footprint disk holds 144,000
posts and its halo 334 posts a side, at 1 mm a hundred times that. Where the posts are
closer than ``track_length / FINEST_CLASS_POSTS`` (1/100 of it: 4.3 cm for a T-72) along an
axis, the classes come from every s-th post along that axis (``class_stride``: the smallest
s putting them at least that far apart, counted from post 0, so that every tiling takes the
same posts): the coarse posts are classified as a DEM of their own (the same passes, the
quantum filter's passes for their spacing) and each post takes the footprint-averaged |H|
of the coarse post nearest to it (ties to the south and east), its class from that; H and
the post area stay every post's own. The work no longer grows with the fineness: the coarse
posts number at most 100 a track length (so they are bounded by the terrain's extent in
track lengths), each tile classifies the coarse posts under it with their halo (at most the
halo of posts L/100 apart, about 90 posts a side; neighbouring tiles compute the overlap
again), and every post costs a fixed amount more (the 3 x 3 differences and the one-sided
fits, whose ``FIT_RADIUS`` is in posts). The coarse posts are read one row of posts at a
time, so memory does not grow with the stride.

Windows are cut at the grid's edges (beyond them every post is NaN: it adds nothing to a
disk sum, a fit or a triangle), so a small DEM is not padded with a halo of NaN.
"""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Callable

import numpy as np

from tankcd_cli.errors import InputError, warn
from tankcd_cli.geometry.post_grid import PostGrid, grid_faces
from tankcd_cli.terrain.curvature.jet import BOUNDARY_NEIGHBOURS, JET_DEGREE, jet_fit_numpy
from tankcd_cli.terrain.curvature.jet_fit import jet_fit
from tankcd_cli.terrain.curvature.mean import OpenVertices, mean_curvature
from tankcd_cli.terrain.grid import post_passes
from tankcd_cli.terrain.grid.quantum import filter_passes, smooth_within_quantum
from tankcd_cli.terrain.regions import NO_CLASS, Thresholds, classify_values
from tankcd_cli.vehicle import Vehicle

GRID_METHODS = ("grid", "cotan", "sphere", "jet")
FIT_RADIUS = 12  # posts (along the coarser axis): holds the 40 nearest even at a DEM's corner (a quarter disk)
MIN_FIT_POSTS = 14  # unknowns of the quartic
DEFAULT_TILE = 512
FAST_MIN_POSTS = 0  # compiled ahead of time, the passes cost nothing to load: every DEM takes them
FINEST_CLASS_POSTS = 100  # posts a track length at most where the classes are computed (module doc)


def class_stride(grid: PostGrid, track_length: float) -> tuple[int, int]:
    """(rows, cols) step between the posts the classes are computed on: 1, or the smallest
    whole number putting them at least ``track_length / FINEST_CLASS_POSTS`` apart."""
    finest = track_length / FINEST_CLASS_POSTS

    def step(h: float) -> int:
        return 1 if h >= finest else int(math.ceil(finest / h - 1e-9))

    return step(float(grid.dy)), step(float(grid.dx))


MIN_POST_SPACING = 1e-6  # m


def fine_posts(grid: PostGrid, vehicle: Vehicle, source: str | None) -> tuple[int, int]:
    """The (rows, cols) stride of the posts the classes come from (``class_stride``):
    (1, 1), or a SetupWarning naming the spacing and what a track feels. Posts closer than
    ``MIN_POST_SPACING`` are an InputError."""
    spacing = min(grid.dx, grid.dy)
    if not spacing >= MIN_POST_SPACING:
        raise InputError(source, f"posts {spacing:g} m apart are closer than {MIN_POST_SPACING:g} m (a micrometre): "
                                 "no terrain is posted so finely; the spacing is in the wrong unit")
    stride = class_stride(grid, vehicle.track_length)
    if stride == (1, 1):
        return stride

    track = vehicle.track_length
    finest = track / FINEST_CLASS_POSTS
    steps = f"{stride[0]}" if stride[0] == stride[1] else f"{stride[0]} (rows) and {stride[1]} (columns)"
    warn(source, f"posts {spacing:g} m apart are far finer than anything the {vehicle.name}'s tracks feel "
                 f"(1/{FINEST_CLASS_POSTS} of its {track:g} m track length is {finest:.3g} m): the classes are "
                 f"computed on one post in {steps} ({min(grid.dx * stride[1], grid.dy * stride[0]):.3g} m apart), "
                 "each post taking the nearest one's; heights and curvature keep every post")
    return stride


def use_compiled(grid: PostGrid) -> bool:
    """Whether to run the compiled twins (the same bits as the numpy passes, which are their oracle)."""
    return grid.rows * grid.cols >= FAST_MIN_POSTS


def _passes(fast: bool):
    """(central differences, post areas, disk sum): the compiled twins or the numpy ones."""
    if fast:
        return post_passes.fd_mean_curvature, post_passes.post_areas, _disk_sum
    return grid_mean_curvature_fd, post_areas, _disk_sum


@dataclass(frozen=True)
class Stencils:
    """Fixed offset lists (row, col) in the order their terms are summed."""

    disk_track: np.ndarray  # radius L/4
    disk_footprint: np.ndarray  # radius L/2
    fit: np.ndarray  # candidate neighbours of a one-sided fit, nearest first, ties by the mesh's vertex order
    halo_rows: int
    halo_cols: int
    reach_rows: int  # how far the two disks together reach
    reach_cols: int


def disk_offsets(radius: float, dx: float, dy: float) -> np.ndarray:
    """(k, 2) (row, col) offsets of the posts within ``radius`` m of a post, row-major."""
    rr = int(math.floor(radius / dy + 1e-9))
    rc = int(math.floor(radius / dx + 1e-9))
    r, c = np.mgrid[-rr:rr + 1, -rc:rc + 1]
    inside = (r * dy) ** 2 + (c * dx) ** 2 <= radius * radius * (1 + 1e-12)
    return np.column_stack([r[inside], c[inside]]).astype(np.int64)


def fit_offsets(dx: float, dy: float) -> np.ndarray:
    """Offsets within FIT_RADIUS posts of the coarser axis, the post itself excluded, nearest
    first; equal distances in the mesh layout's vertex order (south row first, then west)."""
    off = disk_offsets(FIT_RADIUS * max(dx, dy), dx, dy)
    off = off[(off != 0).any(axis=1)]
    d2 = (off[:, 0] * dy) ** 2 + (off[:, 1] * dx) ** 2
    order = np.lexsort((off[:, 1], -off[:, 0], d2))  # north-up rows: a larger row is further south
    return off[order]


def stencils(grid: PostGrid, track_length: float, smoothing_passes: int = 0) -> Stencils:
    """The stencils for this grid and track length; the halo also covers ``smoothing_passes``
    of the quantum filter (``quantum.smooth_within_quantum``: one post each)."""
    dx, dy = grid.dx, grid.dy
    track = disk_offsets(track_length / 4.0, dx, dy)
    foot = disk_offsets(track_length / 2.0, dx, dy)
    fit = fit_offsets(dx, dy)
    reach_r = int(np.abs(track[:, 0]).max() + np.abs(foot[:, 0]).max())
    reach_c = int(np.abs(track[:, 1]).max() + np.abs(foot[:, 1]).max())
    return Stencils(track, foot, fit, reach_r + int(np.abs(fit[:, 0]).max()) + 1 + smoothing_passes,
                    reach_c + int(np.abs(fit[:, 1]).max()) + 1 + smoothing_passes, reach_r, reach_c)


# --- per window --------------------------------------------------------------------

def _shift(a: np.ndarray, dr: int, dc: int, fill) -> np.ndarray:
    """b[r, c] = a[r + dr, c + dc] (``fill`` past the edge)."""
    out = np.full(a.shape, fill, dtype=a.dtype)
    rows, cols = a.shape
    rs, re = max(0, -dr), min(rows, rows - dr)
    cs, ce = max(0, -dc), min(cols, cols - dc)
    if rs < re and cs < ce:
        out[rs:re, cs:ce] = a[rs + dr:re + dr, cs + dc:ce + dc]
    return out


def _disk_sum(a: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Sum of ``a`` over the offsets around every post, in the offsets' order (zero past the edge)."""
    out = np.zeros_like(a)
    rows, cols = a.shape
    for dr, dc in offsets:
        rs, re = max(0, -dr), min(rows, rows - dr)
        cs, ce = max(0, -dc), min(cols, cols - dc)
        if rs < re and cs < ce:
            out[rs:re, cs:ce] += a[rs + dr:re + dr, cs + dc:ce + dc]
    return out


def grid_mean_curvature_fd(z: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """H by central differences at every post (NaN where a 3 x 3 neighbour is missing, and on
    the array's own border)."""
    c = z[1:-1, 1:-1]
    n, s = z[:-2, 1:-1], z[2:, 1:-1]  # row 0 north: the row above is north
    e, w = z[1:-1, 2:], z[1:-1, :-2]
    fx = (e - w) * (0.5 / dx)
    fy = (n - s) * (0.5 / dy)
    fxx = (e - 2 * c + w) * (1.0 / (dx * dx))
    fyy = (n - 2 * c + s) * (1.0 / (dy * dy))
    fxy = ((z[:-2, 2:] - z[:-2, :-2]) - (z[2:, 2:] - z[2:, :-2])) * (0.25 / (dx * dy))
    fx2 = fx * fx
    fy2 = fy * fy
    g = 1.0 + fx2 + fy2
    H = np.full(z.shape, np.nan)
    H[1:-1, 1:-1] = -((1 + fy2) * fxx - 2 * fx * fy * fxy + (1 + fx2) * fyy) / (2.0 * g * np.sqrt(g))
    return H


def open_posts(valid: np.ndarray, method: str) -> np.ndarray:
    """Valid posts the method's formula cannot serve: for ``grid`` a missing one of the 8
    neighbours; for the mesh estimators the posts on a boundary edge of the implicit mesh (an
    edge with one triangle) or in no triangle, as the mesh layout finds them."""
    if method == "grid":
        full = valid.copy()
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                if dr or dc:
                    full &= _shift(valid, dr, dc, False)
        return valid & ~full
    return valid & mesh_boundary_posts(valid)


def mesh_boundary_posts(valid: np.ndarray) -> np.ndarray:
    """Posts on an edge that one triangle of the implicit mesh holds, or in no triangle.

    Per cell (row 0 north) the triangles are (SW, SE, NE) and (SW, NE, NW) when full, the
    triangle of the three valid corners when one is missing; each cell side and diagonal is
    counted over the triangles that hold it (sides over both cells that share them).
    """
    rows, cols = valid.shape
    out = np.zeros((rows, cols), dtype=bool)
    if rows < 2 or cols < 2:
        return valid.copy()
    nw, ne, sw, se = valid[:-1, :-1], valid[:-1, 1:], valid[1:, :-1], valid[1:, 1:]
    count = nw.astype(np.int8) + ne + sw + se
    full, three = count == 4, count == 3
    m_sw, m_se, m_ne, m_nw = three & ~sw, three & ~se, three & ~ne, three & ~nw
    one = np.int8(1)
    # triangles holding each cell edge (0, 1 or 2)
    top = (full | m_sw | m_se) * one            # NW-NE: T2 / (SE,NE,NW) / (SW,NE,NW)
    bottom = (full | m_ne | m_nw) * one         # SW-SE: T1 / (SW,SE,NW) / (SW,SE,NE)
    left = (full | m_se | m_ne) * one           # NW-SW: T2 / (SW,NE,NW) / (SW,SE,NW)
    right = (full | m_sw | m_nw) * one          # NE-SE: T1 / (SE,NE,NW) / (SW,SE,NE)
    diag = (2 * full + m_se + m_nw) * one       # SW-NE: T1 and T2 / (SW,NE,NW) / (SW,SE,NE)
    anti = (m_sw | m_ne) * one                  # NW-SE: (SE,NE,NW) / (SW,SE,NW)
    # horizontal edges (r, c)-(r, c+1): the bottom of the cell above plus the top of the cell below
    horiz = np.zeros((rows, cols - 1), dtype=np.int8)
    horiz[:-1] += top
    horiz[1:] += bottom
    vert = np.zeros((rows - 1, cols), dtype=np.int8)
    vert[:, :-1] += left
    vert[:, 1:] += right
    h1, v1 = horiz == 1, vert == 1
    out[:, :-1] |= h1
    out[:, 1:] |= h1
    out[:-1, :] |= v1
    out[1:, :] |= v1
    d1, a1 = diag == 1, anti == 1
    out[1:, :-1] |= d1  # SW end
    out[:-1, 1:] |= d1  # NE end
    out[:-1, :-1] |= a1  # NW end
    out[1:, 1:] |= a1  # SE end
    # posts in no triangle
    used = np.zeros((rows, cols), dtype=bool)
    any_tri = full | three
    used[:-1, :-1] |= any_tri & nw
    used[:-1, 1:] |= any_tri & ne
    used[1:, :-1] |= any_tri & sw
    used[1:, 1:] |= any_tri & se
    return out | ~used


def post_areas(z: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """A third of the 3-D area of each triangle at every post, m^2 (0 at NODATA)."""
    nw, ne = z[:-1, :-1], z[:-1, 1:]
    sw, se = z[1:, :-1], z[1:, 1:]
    ok = np.stack([np.isfinite(sw), np.isfinite(se), np.isfinite(ne), np.isfinite(nw)])
    count = ok.sum(axis=0)
    zz = [np.nan_to_num(v) for v in (sw, se, ne, nw)]
    # corners in the cell's plane: SW (0, 0), SE (dx, 0), NE (dx, dy), NW (0, dy)
    xy = ((0.0, 0.0), (dx, 0.0), (dx, dy), (0.0, dy))

    def area(i, j, k):
        ax, ay = xy[j][0] - xy[i][0], xy[j][1] - xy[i][1]
        bx, by = xy[k][0] - xy[i][0], xy[k][1] - xy[i][1]
        az, bz = zz[j] - zz[i], zz[k] - zz[i]
        cx = ay * bz - az * by
        cy = az * bx - ax * bz
        cz = ax * by - ay * bx
        return 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)

    full = count == 4
    t1 = np.where(full, area(0, 1, 2), 0.0) / 3.0  # (SW, SE, NE)
    t2 = np.where(full, area(0, 2, 3), 0.0) / 3.0  # (SW, NE, NW)
    share = [t1 + t2, t1, t1 + t2, t2]  # SW, SE, NE, NW
    three = count == 3
    for missing, corners in ((0, (1, 2, 3)), (1, (0, 2, 3)), (2, (0, 1, 3)), (3, (0, 1, 2))):
        sel = three & ~ok[missing]
        if sel.any():
            t = np.where(sel, area(*corners), 0.0) / 3.0
            for k in corners:
                share[k] = share[k] + t
    a = np.zeros(z.shape)
    a[1:, :-1] += share[0]
    a[1:, 1:] += share[1]
    a[:-1, 1:] += share[2]
    a[:-1, :-1] += share[3]
    return a


def one_sided_fit(z: np.ndarray, which: np.ndarray, row0: int, col0: int, dx: float, dy: float,
                  offsets: np.ndarray, k: int = BOUNDARY_NEIGHBOURS, chunk: int = 4096,
                  fast: bool = False) -> np.ndarray:
    """H at the posts ``which`` (bool, window shape) from a quartic over their k nearest valid
    posts among ``offsets``, nearest in 3-D and ties broken as the mesh layout breaks them
    (``curvature.nearest_neighbours``: distances to 1e-9 of the 57th, then vertex order).
    Coordinates come from whole-grid indices (row0, col0: the window's first post), so the
    fit does not depend on the window. ``fast``: the compiled fit (the mesh layout's), else numpy."""
    fit = jet_fit if fast else jet_fit_numpy

    H = np.zeros(z.shape)
    rr_all, cc_all = np.nonzero(which)
    rows, cols = z.shape
    extra = k + 16  # the mesh layout's k + 1 + 16 nearest, less the post itself
    # the mesh layout's tie order: its vertex index grows with the row from the south, then the column
    tie = np.lexsort((offsets[:, 1], -offsets[:, 0]))
    tie_rank = np.empty(len(offsets), dtype=np.int64)
    tie_rank[tie] = np.arange(len(offsets))
    for start in range(0, len(rr_all), chunk):
        rr, cc = rr_all[start:start + chunk], cc_all[start:start + chunk]
        nr = rr[:, None] + offsets[None, :, 0]
        nc = cc[:, None] + offsets[None, :, 1]
        inside = (nr >= 0) & (nr < rows) & (nc >= 0) & (nc < cols)
        nz = z[np.clip(nr, 0, rows - 1), np.clip(nc, 0, cols - 1)]
        ok = inside & np.isfinite(nz)
        ddx = offsets[None, :, 1] * dx
        ddy = offsets[None, :, 0] * dy
        ddz = np.where(ok, nz - z[rr, cc][:, None], 0.0)
        dist = np.where(ok, np.sqrt(ddx * ddx + ddy * ddy + ddz * ddz), np.inf)
        count = ok.sum(axis=1)
        order = np.argsort(dist, axis=1, kind="stable")
        nearest = np.take_along_axis(dist, order[:, :extra], axis=1)
        # a post without a valid neighbour (a lone post in NODATA) has no scale and no fit: 1 keeps
        # its keys finite (inf / inf would be NaN and numpy's RuntimeWarning)
        far = nearest[np.arange(len(rr)), np.maximum(np.minimum(count, extra) - 1, 0)]
        scale = np.where(count > 0, np.maximum(far, 1e-300), 1.0)
        key = np.round(dist / scale[:, None] * 1e9)
        order = np.lexsort((np.broadcast_to(tie_rank, dist.shape), key), axis=-1)
        use = np.minimum(count, k)
        for m in np.unique(use):
            if m < MIN_FIT_POSTS:
                continue  # a speck of terrain: nothing to fit, H stays 0
            sel = np.flatnonzero(use == m)
            taken = order[sel, :m]
            pr = np.take_along_axis(nr[sel], taken, axis=1)
            pc = np.take_along_axis(nc[sel], taken, axis=1)
            cr, ccol = rr[sel], cc[sel]
            allr = np.concatenate([cr, pr.ravel()])
            allc = np.concatenate([ccol, pc.ravel()])
            verts = np.column_stack([(allc + col0) * dx, -(allr + row0) * dy, z[allr, allc]])
            nbr = len(sel) + np.arange(len(sel) * m).reshape(len(sel), m)
            up = np.tile([0.0, 0.0, 1.0], (len(verts), 1))
            H[cr, ccol] = fit(verts, up, np.arange(len(sel)), nbr, JET_DEGREE)
    return H


def _mesh_interior(z: np.ndarray, method: str, row0: int, col0: int, dx: float, dy: float,
                   fast: bool = False) -> np.ndarray:
    """H by a mesh estimator on the window's implicit triangulation (values at open posts unused)."""
    south = z[::-1]  # the mesh layout numbers posts from the south row
    valid = np.isfinite(south)
    vertex = np.full(south.shape, -1, dtype=np.int64)
    vertex[valid] = np.arange(int(valid.sum()))
    rows = z.shape[0]
    s_idx, c_idx = np.nonzero(valid)
    # x, y from whole-grid indices (north row r = rows - 1 - s), so the result does not depend on the window
    verts = np.column_stack([(c_idx + col0) * dx, -((rows - 1 - s_idx) + row0) * dy, south[valid]])
    faces = grid_faces(vertex[::-1])
    H = np.zeros(z.shape)
    if len(faces) == 0:
        return H
    n = len(verts)
    none = np.zeros(n, dtype=bool)
    h = mean_curvature(verts, faces, method, open_verts=OpenVertices(none, none, None), fast=fast)
    out = np.zeros(south.shape)
    out[valid] = h
    return out[::-1]


def window_fields(z: np.ndarray, row0: int, col0: int, grid: PostGrid, st: Stencils, method: str,
                  band: tuple[int, int] = (0, 0), fast: bool = False):
    """H, post area and footprint-averaged |H| over a window (row0, col0: its first post in the
    grid). Values are final only at least ``halo`` posts inside the window's edges (or at the
    grid's own edges, where the window holds NaN beyond). ``band`` (rows, cols): the outer
    posts whose H no final value reads (no fit is spent on them). ``fast``: the compiled twins."""
    dx, dy = grid.dx, grid.dy
    fd, areas, disk = _passes(fast)
    valid = np.isfinite(z)
    if method == "grid":
        H = fd(z, dx, dy)
    else:
        H = _mesh_interior(z, method, row0, col0, dx, dy, fast)
    edge = open_posts(valid, method)
    H = np.where(valid & ~edge, H, 0.0)
    br, bc = band
    if br or bc:
        edge[:br] = False
        edge[edge.shape[0] - br:] = False
        edge[:, :bc] = False
        edge[:, edge.shape[1] - bc:] = False
    if edge.any():
        H = np.where(edge, one_sided_fit(z, edge, row0, col0, dx, dy, st.fit, fast=fast), H)
    H = np.where(np.isfinite(H), H, 0.0)
    area = areas(z, dx, dy)
    a_track = disk(area, st.disk_track)
    ah_track = disk(area * H, st.disk_track)
    with np.errstate(divide="ignore", invalid="ignore"):
        h_track = np.where(a_track > 0, ah_track / a_track, 0.0)
    a_foot = disk(area, st.disk_footprint)
    ah_foot = disk(area * np.abs(h_track), st.disk_footprint)
    with np.errstate(divide="ignore", invalid="ignore"):
        field = np.where(a_foot > 0, ah_foot / a_foot, np.abs(H))  # a post with no triangle: its own |H|
    return np.where(valid, H, np.nan), area, np.where(valid, np.maximum(field, 0.0), np.nan)


@dataclass
class TileResult:
    r0: int
    c0: int
    height: np.ndarray
    mean: np.ndarray
    footprint: np.ndarray
    classes: np.ndarray
    area_by_class: np.ndarray  # (3,) m^2
    valid: int


def classify_tile(z_window: np.ndarray, core: tuple[int, int, int, int], window_origin: tuple[int, int],
                  grid: PostGrid, st: Stencils, method: str, thresholds: Thresholds,
                  fast: bool = False, smoothing: tuple[float, int] | None = None) -> TileResult:
    """Fields and classes of the core rows r0..r1-1, cols c0..c1-1 from a window of heights
    whose first post is window_origin (row, col) in the grid.

    smoothing : (step, passes) of quantized heights: the fields come from the heights smoothed
        within half a step (``quantum.smooth_within_quantum``; ``st`` must cover the passes);
        the result keeps the window's own heights
    """
    r0, c0 = core[0], core[2]
    z, H, area, field = _core_fields(z_window, core, window_origin, grid, st, method, fast, smoothing)
    return _classified(r0, c0, z, H, area, field, thresholds)


def _core_fields(z_window, core, window_origin, grid, st, method, fast, smoothing):
    """(z, H, area, footprint field) over the core of a window (see ``classify_tile``)."""
    r0, r1, c0, c1 = core
    wr, wc = window_origin
    # the outer posts of the halo only feed fits' neighbourhoods: their own H is never read (a
    # window cut at the grid's edge has a narrower halo there: the narrower side decides)
    wr1, wc1 = wr + z_window.shape[0], wc + z_window.shape[1]
    band = (max(min(r0 - wr, wr1 - r1) - st.reach_rows, 0), max(min(c0 - wc, wc1 - c1) - st.reach_cols, 0))
    z_fields = z_window
    if smoothing is not None and smoothing[1] > 0:
        z_fields = smooth_within_quantum(z_window, smoothing[0], smoothing[1])
    H, area, field = window_fields(z_fields, wr, wc, grid, st, method, band, fast)
    sl = np.s_[r0 - wr:r1 - wr, c0 - wc:c1 - wc]
    return z_window[sl], H[sl], area[sl], field[sl]


def _classified(r0: int, c0: int, z, H, area, field, thresholds: Thresholds) -> TileResult:
    valid = np.isfinite(z)
    classes = np.where(valid, classify_values(np.nan_to_num(field), thresholds), NO_CLASS).astype(np.uint8)
    by_class = np.bincount(classes[valid], weights=area[valid], minlength=3)[:3]
    return TileResult(r0, c0, z, H, field, classes, by_class, int(valid.sum()))


@dataclass(frozen=True)
class TilePlan:
    """How a grid's tiles are read and classified (module doc).

    st : the stencils over the grid's own posts (with a stride: the fits' only)
    stride : (rows, cols) step of the coarse posts the classes come from; (1, 1): every post
    coarse, coarse_st, coarse_smoothing : the coarse posts' grid, stencils and quantum filter
        (None with stride (1, 1))
    """

    grid: PostGrid
    st: Stencils
    smoothing: tuple[float, int] | None
    stride: tuple[int, int] = (1, 1)
    coarse: PostGrid | None = None
    coarse_st: Stencils | None = None
    coarse_smoothing: tuple[float, int] | None = None


def tile_plan(grid: PostGrid, track_length: float, thresholds: Thresholds,
              smoothing: tuple[float, int] | None = None) -> TilePlan:
    """The :class:`TilePlan` of a grid: every post, or the classes on coarse posts where the
    posts are finer than ``track_length / FINEST_CLASS_POSTS`` (``class_stride``)."""
    passes = smoothing[1] if smoothing else 0
    sr, sc = class_stride(grid, track_length)
    if (sr, sc) == (1, 1):
        return TilePlan(grid, stencils(grid, track_length, passes), smoothing)

    fit = fit_offsets(grid.dx, grid.dy)
    own = np.zeros((1, 2), dtype=np.int64)
    st = Stencils(own, own, fit, int(np.abs(fit[:, 0]).max()) + 1 + passes, int(np.abs(fit[:, 1]).max()) + 1 + passes,
                  0, 0)
    coarse = dataclasses.replace(grid, rows=(grid.rows - 1) // sr + 1, cols=(grid.cols - 1) // sc + 1,
                                 dx=grid.dx * sc, dy=grid.dy * sr)
    coarse_smoothing = None
    if smoothing:
        coarse_passes = filter_passes(smoothing[0], coarse.dx, coarse.dy, thresholds.flat)
        coarse_smoothing = (smoothing[0], coarse_passes) if coarse_passes else None
    coarse_st = stencils(coarse, track_length, coarse_smoothing[1] if coarse_smoothing else 0)
    return TilePlan(grid, st, smoothing, (sr, sc), coarse, coarse_st, coarse_smoothing)


def _nearest_coarse(index: np.ndarray, step: int, count: int) -> np.ndarray:
    """The coarse post nearest to each post ``index`` along an axis (ties to the higher)."""
    return np.minimum((np.asarray(index) + step // 2) // step, count - 1)


def fetch_tile(read: Callable[[int, int, int, int], np.ndarray], plan: TilePlan, core) -> tuple:
    """The heights a tile needs, read through ``read`` (not thread-safe: call it from one thread)."""
    r0, r1, c0, c1 = core
    st, grid = plan.st, plan.grid
    # the window is cut at the grid's edges: beyond them every post is NaN, which adds nothing
    # to a disk sum (zero area), to a fit (no neighbour) or to a triangle, so the result is the
    # same bits as with the whole halo
    wr, wc = max(r0 - st.halo_rows, 0), max(c0 - st.halo_cols, 0)
    z = read(wr, min(r1 + st.halo_rows, grid.rows), wc, min(c1 + st.halo_cols, grid.cols))
    if plan.coarse is None:
        return z, (wr, wc)
    (sr, sc), cg, cst = plan.stride, plan.coarse, plan.coarse_st
    R0, R1 = int(_nearest_coarse(r0, sr, cg.rows)), int(_nearest_coarse(r1 - 1, sr, cg.rows)) + 1
    C0, C1 = int(_nearest_coarse(c0, sc, cg.cols)), int(_nearest_coarse(c1 - 1, sc, cg.cols)) + 1
    Rw, Cw = max(R0 - cst.halo_rows, 0), max(C0 - cst.halo_cols, 0)
    Rw1, Cw1 = min(R1 + cst.halo_rows, cg.rows), min(C1 + cst.halo_cols, cg.cols)
    zc = np.empty((Rw1 - Rw, Cw1 - Cw))
    f0, f1 = Cw * sc, (Cw1 - 1) * sc + 1
    for i, R in enumerate(range(Rw, Rw1)):  # one row of posts at a time: memory does not grow with the stride
        zc[i] = read(R * sr, R * sr + 1, f0, f1)[0, ::sc]
    return z, (wr, wc), zc, (Rw, Cw), (R0, R1, C0, C1)


def classify_fetched(plan: TilePlan, core, fetched: tuple, method: str, thresholds: Thresholds,
                     fast: bool = False) -> TileResult:
    """The :class:`TileResult` of a tile from what :func:`fetch_tile` read."""
    if plan.coarse is None:
        z, origin = fetched
        return classify_tile(z, core, origin, plan.grid, plan.st, method, thresholds, fast, plan.smoothing)
    z_window, origin, zc, coarse_origin, coarse_core = fetched
    r0, r1, c0, c1 = core
    z, H, area, _ = _core_fields(z_window, core, origin, plan.grid, plan.st, method, fast, plan.smoothing)
    _, _, _, coarse_field = _core_fields(zc, coarse_core, coarse_origin, plan.coarse, plan.coarse_st, method, fast,
                                         plan.coarse_smoothing)
    (sr, sc), R0, C0 = plan.stride, coarse_core[0], coarse_core[2]
    rows = _nearest_coarse(np.arange(r0, r1), sr, plan.coarse.rows) - R0
    cols = _nearest_coarse(np.arange(c0, c1), sc, plan.coarse.cols) - C0
    field = coarse_field[np.ix_(rows, cols)]
    field = np.where(np.isfinite(field), field, np.abs(H))  # the nearest coarse post is NODATA: the post's own |H|
    return _classified(r0, c0, z, H, area, np.where(np.isfinite(z), field, np.nan), thresholds)


def tiles_of(grid: PostGrid, tile):
    """Core windows (r0, r1, c0, c1) in row-major order; ``tile`` a side or (rows, cols)."""
    th, tw = (tile, tile) if np.isscalar(tile) else tile
    for r0 in range(0, grid.rows, th):
        for c0 in range(0, grid.cols, tw):
            yield r0, min(r0 + th, grid.rows), c0, min(c0 + tw, grid.cols)


def classify_grid_tiles(read: Callable[[int, int, int, int], np.ndarray], grid: PostGrid, method: str,
                        track_length: float, thresholds: Thresholds, tile=DEFAULT_TILE, jobs: int = 1,
                        on_tile: Callable[[TileResult], None] | None = None,
                        progress: Callable[[int, int, int], None] | None = None,
                        smoothing: tuple[float, int] | None = None) -> None:
    """Classify every tile and hand each result to ``on_tile`` in row-major order.

    read(r0, r1, c0, c1) : heights (float64, NaN NODATA and beyond the grid) of a window
    tile : posts per tile side, or (rows, cols)
    jobs : worker threads (numpy releases the GIL in the array work)
    progress(tiles_done, tiles_total, posts_done)
    smoothing : (step, passes) of quantized heights (see ``classify_tile``), or None
    """
    if method not in GRID_METHODS:
        raise ValueError(f"unknown curvature method {method!r}; choose one of {', '.join(GRID_METHODS)}")
    plan = tile_plan(grid, track_length, thresholds, smoothing)
    cores = list(tiles_of(grid, tile))
    fast = use_compiled(grid)

    def work(core, fetched):
        return classify_fetched(plan, core, fetched, method, thresholds, fast)

    def fetch(core):
        return (fetch_tile(read, plan, core),)

    count = {"tiles": 0, "posts": 0}

    def deliver(result):
        count["tiles"] += 1
        count["posts"] += result.height.size
        if on_tile:
            on_tile(result)
        if progress:
            progress(count["tiles"], len(cores), count["posts"])

    if jobs <= 1:
        for core in cores:
            deliver(work(core, *fetch(core)))
        return

    pool = ThreadPoolExecutor(max_workers=jobs)
    try:
        pending = []
        for core in cores:
            pending.append(pool.submit(work, core, *fetch(core)))
            if len(pending) >= 2 * jobs:  # bounded: at most 2 x jobs windows in memory
                deliver(pending.pop(0).result())
        for fut in pending:
            deliver(fut.result())
    except BaseException:  # an error or a signal: the tiles not begun are dropped, not worked through
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
