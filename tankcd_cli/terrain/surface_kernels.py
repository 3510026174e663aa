"""Compiled point location for :mod:`tankcd_cli.terrain.surface` (numba, cached on disk)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from tankcd_cli.terrain.grid_kernels import full_cell

BARY_EPS = 1e-9  # points this close (in barycentric units) to a triangle's edge count as inside


@njit(cache=True, inline="always")
def cell_of(x, y, origin, size, ny, nx):  # pragma: no cover - compiled
    col = int(np.floor((x - origin[0]) / size[0]))
    row = int(np.floor((y - origin[1]) / size[1]))
    # a point on the far edge of the last cell belongs to it
    if col == nx and x - origin[0] <= nx * size[0] * (1 + 1e-12):
        col = nx - 1
    if row == ny and y - origin[1] <= ny * size[1] * (1 + 1e-12):
        row = ny - 1
    return row, col


@njit(cache=True, inline="always")
def inside_triangle(x, y, V, F, f):  # pragma: no cover - compiled
    a = F[f, 0]
    b = F[f, 1]
    c = F[f, 2]
    ax = V[a, 0]
    ay = V[a, 1]
    e1x = V[b, 0] - ax
    e1y = V[b, 1] - ay
    e2x = V[c, 0] - ax
    e2y = V[c, 1] - ay
    det = e1x * e2y - e1y * e2x
    if det == 0.0:
        return False
    px = x - ax
    py = y - ay
    l1 = (px * e2y - py * e2x) / det
    l2 = (e1x * py - e1y * px) / det
    return l1 >= -BARY_EPS and l2 >= -BARY_EPS and l1 + l2 <= 1.0 + BARY_EPS


@njit(cache=True)
def _best_in_cell(x, y, row, col, V, F, plane, ny, nx, start, cell_face):  # pragma: no cover - compiled
    if row < 0 or col < 0 or row >= ny or col >= nx:
        return -1
    cell = row * nx + col
    best = -1
    best_z = -np.inf
    for s in range(start[cell], start[cell + 1]):
        f = cell_face[s]
        if np.isnan(plane[f, 1]):
            continue  # vertical face: no height of its own
        if inside_triangle(x, y, V, F, f):
            z = plane[f, 0] + plane[f, 1] * x + plane[f, 2] * y
            if z > best_z:
                best_z = z
                best = f
    return best


@njit(cache=True)
def locate_one(x, y, V, F, plane, origin, size, ny, nx, start, cell_face):  # pragma: no cover - compiled
    """The face under one local point, -1 if none (the highest on overhangs)."""
    row, col = cell_of(x, y, origin, size, ny, nx)
    best = _best_in_cell(x, y, row, col, V, F, plane, ny, nx, start, cell_face)
    if best < 0:
        # a point on a cell's border may lie only in a neighbour's triangle
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                if best < 0 and (dr != 0 or dc != 0):
                    best = _best_in_cell(x, y, row + dr, col + dc, V, F, plane, ny, nx, start, cell_face)
    return best


@njit(cache=True, parallel=True)
def locate_faces(px, py, V, F, plane, origin, size, ny, nx, start, cell_face):  # pragma: no cover - compiled
    """Face under each local point, -1 if none; on overhangs the highest face."""
    out = np.full(px.shape[0], -1, np.int64)
    for i in prange(px.shape[0]):
        x = px[i]
        y = py[i]
        if not (np.isfinite(x) and np.isfinite(y)):
            continue
        out[i] = locate_one(x, y, V, F, plane, origin, size, ny, nx, start, cell_face)
    return out


@njit(cache=True, parallel=True)
def heights_slopes(px, py, post_z, post_origin, post_size, V, F, plane, origin, size, ny, nx, start, cell_face):  # pragma: no cover - compiled
    """Height and gradient (dz/dx, dz/dy) of the terrain at local points; NaN off the terrain.

    ``post_z`` (rows, cols), NaN for NODATA, is a DEM's post raster: a full DEM
    cell is evaluated by arithmetic on its four posts (split along the SW-NE
    diagonal, as the mesh is). Anything else (cells with a missing post,
    irregular meshes: an empty ``post_z``) goes through the located face.
    """
    n = px.shape[0]
    z = np.full(n, np.nan)
    gx = np.full(n, np.nan)
    gy = np.full(n, np.nan)
    for i in prange(n):
        z[i], gx[i], gy[i] = height_one(px[i], py[i], post_z, post_origin, post_size, V, F, plane, origin, size,
                                        ny, nx, start, cell_face)
    return z, gx, gy


@njit(cache=True)
def height_one(x, y, post_z, post_origin, post_size, V, F, plane, origin, size, ny, nx, start, cell_face):  # pragma: no cover - compiled
    """Height and gradient at one local point (NaN off the terrain): see ``heights_slopes``."""
    if not (np.isfinite(x) and np.isfinite(y)):
        return np.nan, np.nan, np.nan
    rows = post_z.shape[0]
    cols = post_z.shape[1]
    if rows >= 2 and cols >= 2:
        u = (x - post_origin[0]) / post_size[0]
        v = (y - post_origin[1]) / post_size[1]
        c = int(np.floor(u))
        r = int(np.floor(v))
        if c == cols - 1 and u <= cols - 1 + 1e-9:
            c = cols - 2
        if r == rows - 1 and v <= rows - 1 + 1e-9:
            r = rows - 2
        if 0 <= c < cols - 1 and 0 <= r < rows - 1:
            z, gx, gy = full_cell(post_z, r, c, u - c, v - r, post_size[0], post_size[1])
            if np.isfinite(z):
                return z, gx, gy
    best = locate_one(x, y, V, F, plane, origin, size, ny, nx, start, cell_face)
    if best < 0:
        return np.nan, np.nan, np.nan
    return plane[best, 0] + plane[best, 1] * x + plane[best, 2] * y, plane[best, 1], plane[best, 2]


@njit(cache=True, parallel=True)
def highest_above(R, position, points, post_z, post_origin, post_size, V, F, plane, origin, size, ny, nx, start,
                  cell_face):  # pragma: no cover - compiled
    """For each pose, how far the ground rises above the body points (k, 3) moved by x -> R x + p
    (local coordinates): max over the points on terrain of ground - z; -inf if none is on terrain."""
    n = R.shape[0]
    out = np.full(n, -np.inf)
    for i in prange(n):
        worst = -np.inf
        for k in range(points.shape[0]):
            wx = R[i, 0, 0] * points[k, 0] + R[i, 0, 1] * points[k, 1] + R[i, 0, 2] * points[k, 2] + position[i, 0]
            wy = R[i, 1, 0] * points[k, 0] + R[i, 1, 1] * points[k, 1] + R[i, 1, 2] * points[k, 2] + position[i, 1]
            wz = R[i, 2, 0] * points[k, 0] + R[i, 2, 1] * points[k, 1] + R[i, 2, 2] * points[k, 2] + position[i, 2]
            g, _, _ = height_one(wx, wy, post_z, post_origin, post_size, V, F, plane, origin, size, ny, nx, start,
                                 cell_face)
            if np.isfinite(g) and g - wz > worst:
                worst = g - wz
        out[i] = worst
    return out
