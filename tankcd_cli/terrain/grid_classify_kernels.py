"""Compiled twins of the per-post passes of ``grid_classify`` (numba, cached on disk, no GIL).

Each kernel performs the same floating-point operations in the same order as
its numpy twin in ``grid_classify.py`` (no fused multiply-add, no
reassociation), so the two give the same bits; the tests hold them to it.
The numpy twins serve small DEMs, where importing numba would cost more than
it saves. (The disk sums stay numpy: offset by offset over whole arrays they
run at memory speed already.)
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def fd_mean_curvature(z, dx, dy):  # pragma: no cover - compiled
    """``grid_mean_curvature_fd``: H by central differences (NaN on the border and where a
    neighbour is missing); z (rows, cols) row 0 north."""
    rows, cols = z.shape
    H = np.full((rows, cols), np.nan)
    hx = 0.5 / dx
    hy = 0.5 / dy
    ixx = 1.0 / (dx * dx)
    iyy = 1.0 / (dy * dy)
    ixy = 0.25 / (dx * dy)
    for r in range(1, rows - 1):
        for c in range(1, cols - 1):
            cc = z[r, c]
            n = z[r - 1, c]
            s = z[r + 1, c]
            e = z[r, c + 1]
            w = z[r, c - 1]
            fx = (e - w) * hx
            fy = (n - s) * hy
            fxx = (e - 2 * cc + w) * ixx
            fyy = (n - 2 * cc + s) * iyy
            fxy = ((z[r - 1, c + 1] - z[r - 1, c - 1]) - (z[r + 1, c + 1] - z[r + 1, c - 1])) * ixy
            fx2 = fx * fx
            fy2 = fy * fy
            g = 1.0 + fx2 + fy2
            H[r, c] = -((1 + fy2) * fxx - 2 * fx * fy * fxy + (1 + fx2) * fyy) / (2.0 * g * np.sqrt(g))
    return H


@njit(cache=True, inline="always")
def _area(ax, ay, bx, by, az, bz):  # pragma: no cover - compiled
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    return 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)


@njit(cache=True, inline="always")
def _corner_area(i, j, k, x, y, zz):  # pragma: no cover - compiled
    return _area(x[j] - x[i], y[j] - y[i], x[k] - x[i], y[k] - y[i], zz[j] - zz[i], zz[k] - zz[i])


@njit(cache=True, nogil=True)
def post_areas(z, dx, dy):  # pragma: no cover - compiled
    """``grid_classify.post_areas``: a third of the 3-D area of each triangle at every post."""
    rows, cols = z.shape
    share = np.zeros((4, rows - 1, cols - 1))  # SW, SE, NE, NW corner of each cell
    x = np.array([0.0, dx, dx, 0.0])
    y = np.array([0.0, 0.0, dy, dy])
    zz = np.empty(4)
    ok = np.empty(4, np.bool_)
    for r in range(rows - 1):
        for c in range(cols - 1):
            v = (z[r + 1, c], z[r + 1, c + 1], z[r, c + 1], z[r, c])  # SW, SE, NE, NW
            count = 0
            for k in range(4):
                ok[k] = np.isfinite(v[k])
                zz[k] = v[k] if ok[k] else 0.0
                count += ok[k]
            if count == 4:
                t1 = _corner_area(0, 1, 2, x, y, zz) / 3.0
                t2 = _corner_area(0, 2, 3, x, y, zz) / 3.0
                share[0, r, c] = t1 + t2
                share[1, r, c] = t1
                share[2, r, c] = t1 + t2
                share[3, r, c] = t2
            elif count == 3:
                if not ok[0]:
                    t = _corner_area(1, 2, 3, x, y, zz) / 3.0
                elif not ok[1]:
                    t = _corner_area(0, 2, 3, x, y, zz) / 3.0
                elif not ok[2]:
                    t = _corner_area(0, 1, 3, x, y, zz) / 3.0
                else:
                    t = _corner_area(0, 1, 2, x, y, zz) / 3.0
                for k in range(4):
                    if ok[k]:
                        share[k, r, c] = t
    a = np.zeros((rows, cols))
    # the numpy twin's order: every SW share, then SE, NE, NW
    for r in range(rows - 1):
        for c in range(cols - 1):
            a[r + 1, c] += share[0, r, c]
    for r in range(rows - 1):
        for c in range(cols - 1):
            a[r + 1, c + 1] += share[1, r, c]
    for r in range(rows - 1):
        for c in range(cols - 1):
            a[r, c + 1] += share[2, r, c]
    for r in range(rows - 1):
        for c in range(cols - 1):
            a[r, c] += share[3, r, c]
    return a
