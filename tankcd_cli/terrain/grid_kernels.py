"""Compiled height and class queries on a DEM held only as posts (numba, cached on disk).

The surface is the grid layout's implicit one (docs/formats.md): each cell split
along its SW-NE diagonal into (SW, SE, NE) and (SW, NE, NW); a cell with three
valid posts carries the one triangle of those three; fewer, nothing.

Every kernel takes a *window* of the grid: ``post_z`` (rows, cols), south row
first, NaN at NODATA, whose post [0, 0] is post [r_off, c_off] of the whole
grid (row index from the south), and ``post_origin``, the local x, y of the
whole grid's post [0, 0]. Cell indices and in-cell fractions are computed in
the whole grid's indices, so a result never depends on the window it was read
through (a replay split into parts gives the same bytes as one run).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

BARY_EPS = 1e-9  # as the mesh locator: points this close (barycentric units) to an edge count as inside


@njit(cache=True, inline="always")
def full_cell(post_z, wr, wc, fx, fy, dx, dy):  # pragma: no cover - compiled
    """Height and gradient at fractions (fx, fy) of cell [wr, wc] of ``post_z`` (south row first)
    when its four posts are valid (the SW-NE split); NaN otherwise."""
    sw = post_z[wr, wc]
    se = post_z[wr, wc + 1]
    ne = post_z[wr + 1, wc + 1]
    nw = post_z[wr + 1, wc]
    if not (np.isfinite(sw) and np.isfinite(se) and np.isfinite(ne) and np.isfinite(nw)):
        return np.nan, np.nan, np.nan
    if fx >= fy:
        return sw + fx * (se - sw) + fy * (ne - se), (se - sw) / dx, (ne - se) / dy
    return sw + fy * (nw - sw) + fx * (ne - nw), (ne - nw) / dx, (nw - sw) / dy


@njit(cache=True, inline="always")
def _triangle(ux, uy, uz, vx, vy, vz, wx, wy, wz, fx, fy, dx, dy):  # pragma: no cover - compiled
    """Height and gradient of the plane through three cell-fraction points at (fx, fy), and
    whether (fx, fy) lies in their triangle (with BARY_EPS)."""
    e1x = vx - ux
    e1y = vy - uy
    e2x = wx - ux
    e2y = wy - uy
    det = e1x * e2y - e1y * e2x
    px = fx - ux
    py = fy - uy
    l1 = (px * e2y - py * e2x) / det
    l2 = (e1x * py - e1y * px) / det
    inside = l1 >= -BARY_EPS and l2 >= -BARY_EPS and l1 + l2 <= 1.0 + BARY_EPS
    # plane z = uz + a fx + b fy in cell units, then per metre
    a = ((vz - uz) * e2y - (wz - uz) * e1y) / det
    b = (e1x * (wz - uz) - e2x * (vz - uz)) / det
    return uz + a * px + b * py, a / dx, b / dy, inside


@njit(cache=True)
def _partial_cell(post_z, r, c, r_off, c_off, fx, fy, dx, dy):  # pragma: no cover - compiled
    """Height and gradient at (fx, fy) in cell (r, c) (whole-grid indices) when the cell has
    exactly three valid posts and the point is in their triangle; NaN otherwise."""
    rows = post_z.shape[0]
    cols = post_z.shape[1]
    wr = r - r_off
    wc = c - c_off
    if wr < 0 or wc < 0 or wr > rows - 2 or wc > cols - 2:
        return np.nan, np.nan, np.nan
    sw = post_z[wr, wc]
    se = post_z[wr, wc + 1]
    ne = post_z[wr + 1, wc + 1]
    nw = post_z[wr + 1, wc]
    ok_sw = np.isfinite(sw)
    ok_se = np.isfinite(se)
    ok_ne = np.isfinite(ne)
    ok_nw = np.isfinite(nw)
    count = int(ok_sw) + int(ok_se) + int(ok_ne) + int(ok_nw)
    if count == 4:
        # a full cell reached from a neighbour (a point on the shared border)
        if fx >= fy:
            z, gx, gy, inside = _triangle(0.0, 0.0, sw, 1.0, 0.0, se, 1.0, 1.0, ne, fx, fy, dx, dy)
        else:
            z, gx, gy, inside = _triangle(0.0, 0.0, sw, 1.0, 1.0, ne, 0.0, 1.0, nw, fx, fy, dx, dy)
    elif count == 3:
        if not ok_sw:
            z, gx, gy, inside = _triangle(1.0, 0.0, se, 1.0, 1.0, ne, 0.0, 1.0, nw, fx, fy, dx, dy)
        elif not ok_se:
            z, gx, gy, inside = _triangle(0.0, 0.0, sw, 1.0, 1.0, ne, 0.0, 1.0, nw, fx, fy, dx, dy)
        elif not ok_ne:
            z, gx, gy, inside = _triangle(0.0, 0.0, sw, 1.0, 0.0, se, 0.0, 1.0, nw, fx, fy, dx, dy)
        else:
            z, gx, gy, inside = _triangle(0.0, 0.0, sw, 1.0, 0.0, se, 1.0, 1.0, ne, fx, fy, dx, dy)
    else:
        return np.nan, np.nan, np.nan
    if not inside:
        return np.nan, np.nan, np.nan
    return z, gx, gy


@njit(cache=True)
def grid_height_one(x, y, post_z, post_origin, post_size, r_off, c_off, grid_rows, grid_cols):  # pragma: no cover - compiled
    """Height and gradient (dz/dx, dz/dy) at one local point; NaN off the terrain.

    grid_rows, grid_cols : the whole grid's size in posts (a point on its far edge belongs
    to the last cell, as in the mesh locator).
    """
    if not (np.isfinite(x) and np.isfinite(y)):
        return np.nan, np.nan, np.nan
    dx = post_size[0]
    dy = post_size[1]
    u = (x - post_origin[0]) / dx
    v = (y - post_origin[1]) / dy
    c = int(np.floor(u))
    r = int(np.floor(v))
    if c == grid_cols - 1 and u <= grid_cols - 1 + 1e-9:
        c = grid_cols - 2
    if r == grid_rows - 1 and v <= grid_rows - 1 + 1e-9:
        r = grid_rows - 2
    if c < -1 or r < -1 or c > grid_cols - 1 or r > grid_rows - 1:
        return np.nan, np.nan, np.nan
    rows = post_z.shape[0]
    cols = post_z.shape[1]
    wr = r - r_off
    wc = c - c_off
    if 0 <= wr <= rows - 2 and 0 <= wc <= cols - 2:
        z, gx, gy = full_cell(post_z, wr, wc, u - c, v - r, dx, dy)
        if np.isfinite(z):
            return z, gx, gy
    # a cell with a missing post, or a point just outside a cell: its triangle, then the
    # neighbours' (a point on a cell border may lie only in a neighbour's triangle)
    z, gx, gy = _partial_cell(post_z, r, c, r_off, c_off, u - c, v - r, dx, dy)
    if np.isfinite(z):
        return z, gx, gy
    best = -np.inf
    bx = np.nan
    by = np.nan
    for dr in range(-1, 2):
        for dc in range(-1, 2):
            if best == -np.inf and (dr != 0 or dc != 0):
                z, gx, gy = _partial_cell(post_z, r + dr, c + dc, r_off, c_off, u - (c + dc), v - (r + dr), dx, dy)
                if np.isfinite(z):
                    best = z
                    bx = gx
                    by = gy
    if best == -np.inf:
        return np.nan, np.nan, np.nan
    return best, bx, by


@njit(cache=True, parallel=True)
def grid_heights_slopes(px, py, post_z, post_origin, post_size, r_off, c_off, grid_rows, grid_cols):  # pragma: no cover - compiled
    """Height and gradient at local points (N,); NaN off the terrain (see ``grid_height_one``)."""
    n = px.shape[0]
    z = np.full(n, np.nan)
    gx = np.full(n, np.nan)
    gy = np.full(n, np.nan)
    for i in prange(n):
        z[i], gx[i], gy[i] = grid_height_one(px[i], py[i], post_z, post_origin, post_size, r_off, c_off, grid_rows,
                                             grid_cols)
    return z, gx, gy


@njit(cache=True, parallel=True)
def grid_worst_class(px, py, yaw, su, sv, classes, post_origin, post_size, r_off, c_off):  # pragma: no cover - compiled
    """Highest class code among the posts nearest to sample offsets (su, sv) of each footprint
    (local centres px, py, headings yaw); 255 where none is known. ``classes`` is a window
    like ``post_z`` (255 at NODATA)."""
    rows = classes.shape[0]
    cols = classes.shape[1]
    out = np.full(px.shape[0], 255, np.uint8)
    for i in prange(px.shape[0]):
        co = np.cos(yaw[i])
        si = np.sin(yaw[i])
        worst = -1
        for k in range(su.shape[0]):
            x = px[i] + co * su[k] - si * sv[k]
            y = py[i] + si * su[k] + co * sv[k]
            col = int(np.floor((x - post_origin[0]) / post_size[0] + 0.5)) - c_off
            row = int(np.floor((y - post_origin[1]) / post_size[1] + 0.5)) - r_off
            if 0 <= row < rows and 0 <= col < cols:
                c = classes[row, col]
                if c != 255 and c > worst:
                    worst = c
        if worst >= 0:
            out[i] = worst
    return out
