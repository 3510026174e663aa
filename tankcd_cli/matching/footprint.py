"""The ground under the two track contact patches, exactly (compiled, batched over poses).

For a piecewise-linear terrain the highest ground point relative to any plane
over a convex patch lies at a vertex of some terrain triangle clipped to the
patch. So each triangle overlapping a patch is clipped to it
(Sutherland-Hodgman), and the clipped polygons' corners are the exact
constraint set: for the rigid-hull reference (the lowest plane above all of
them, over the footprint centre) and for any matcher's penetration (the
highest of them above its plane). The clipped areas also tell how much of the
footprint lies on the terrain.

Patches are convex quadrilaterals in the heading frame (u forward, v left,
horizontal, origin at the footprint centre): the vertical projections of the
tilted hull's contact rectangles.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from tankcd_cli.geometry.support_plane import support_plane

MAX_POLY = 16


@njit(cache=True)
def _clip(pu, pv, pz, count, au, av, bu, bv, ou, ov, oz):  # pragma: no cover - compiled
    """Clip polygon (pu, pv, pz)[:count] to the left of the directed edge a->b.

    Writes the result into (ou, ov, oz) (scratch of MAX_POLY) and copies it back; returns its size.
    """
    n = 0
    eu = bu - au
    ev = bv - av
    for i in range(count):
        j = (i + 1) % count
        si = eu * (pv[i] - av) - ev * (pu[i] - au)
        sj = eu * (pv[j] - av) - ev * (pu[j] - au)
        if si >= 0:
            ou[n] = pu[i]
            ov[n] = pv[i]
            oz[n] = pz[i]
            n += 1
        if (si >= 0) != (sj >= 0):
            t = si / (si - sj)
            ou[n] = pu[i] + t * (pu[j] - pu[i])
            ov[n] = pv[i] + t * (pv[j] - pv[i])
            oz[n] = pz[i] + t * (pz[j] - pz[i])
            n += 1
    for i in range(n):
        pu[i] = ou[i]
        pv[i] = ov[i]
        pz[i] = oz[i]
    return n


@njit(cache=True, inline="always")
def _quad_box(cx, cy, co, si, quad):  # pragma: no cover - compiled
    """The bounding box (xmin, xmax, ymin, ymax) of a patch turned by the heading and placed at (cx, cy)."""
    xmin = np.inf
    xmax = -np.inf
    ymin = np.inf
    ymax = -np.inf
    for k in range(4):
        wx = cx + co * quad[k, 0] - si * quad[k, 1]
        wy = cy + si * quad[k, 0] + co * quad[k, 1]
        xmin = min(xmin, wx)
        xmax = max(xmax, wx)
        ymin = min(ymin, wy)
        ymax = max(ymax, wy)
    return xmin, xmax, ymin, ymax


@njit(cache=True)
def _patch_points(cx, cy, co, si, quad, V, F, plane, origin, size, ny, nx, start, cell_face, listed_once, cand,
                  pu, pv, pz, ou, ov, oz, out_u, out_v, out_z, used):  # pragma: no cover - compiled
    """Append the clipped-triangle corners under one patch; returns (count, covered area).

    cand and pu .. oz are the caller's scratch (cand grows here if too small); listed_once
    says no face is listed in two cells (a DEM's cells), so no sort is needed to skip repeats.
    """
    xmin, xmax, ymin, ymax = _quad_box(cx, cy, co, si, quad)
    c0 = max(int(np.floor((xmin - origin[0]) / size[0])), 0)
    c1 = min(int(np.floor((xmax - origin[0]) / size[0])), nx - 1)
    r0 = max(int(np.floor((ymin - origin[1]) / size[1])), 0)
    r1 = min(int(np.floor((ymax - origin[1]) / size[1])), ny - 1)
    if c0 > c1 or r0 > r1:
        return used, 0.0
    total = 0
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            total += start[r * nx + c + 1] - start[r * nx + c]
    if total > cand.shape[0]:
        cand = np.empty(total, np.int64)
    t = 0
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            cell = r * nx + c
            for s in range(start[cell], start[cell + 1]):
                cand[t] = cell_face[s]
                t += 1
    if not listed_once:
        cand[:total].sort()
    area = 0.0
    for s in range(total):
        f = cand[s]
        if not listed_once and s > 0 and f == cand[s - 1]:
            continue  # a triangle listed in several cells
        if np.isnan(plane[f, 1]):
            continue
        i, j, k = F[f, 0], F[f, 1], F[f, 2]
        used, a = _append_clipped(cx, cy, co, si, quad, V[i, 0], V[i, 1], V[i, 2], V[j, 0], V[j, 1], V[j, 2],
                                  V[k, 0], V[k, 1], V[k, 2], pu, pv, pz, ou, ov, oz, out_u, out_v, out_z, used)
        area += a
        if used < 0:
            return -1, area  # caller grows the buffer and tries again
    return used, area


@njit(cache=True, inline="always")
def _append_clipped(cx, cy, co, si, quad, x0, y0, z0, x1, y1, z1, x2, y2, z2, pu, pv, pz, ou, ov, oz, out_u, out_v,
                    out_z, used):  # pragma: no cover - compiled
    """Clip one triangle (local x, y, z corners) to the patch and append the corners; returns
    (new count or -1 when the buffer is too small, clipped area)."""
    xs = (x0, x1, x2)
    ys = (y0, y1, y2)
    zs = (z0, z1, z2)
    for k in range(3):
        dx = xs[k] - cx
        dy = ys[k] - cy
        pu[k] = co * dx + si * dy
        pv[k] = -si * dx + co * dy
        pz[k] = zs[k]
    n = 3
    for k in range(4):
        n = _clip(pu, pv, pz, n, quad[k, 0], quad[k, 1], quad[(k + 1) % 4, 0], quad[(k + 1) % 4, 1], ou, ov, oz)
        if n == 0:
            break
    if n < 3:
        return used, 0.0
    a2 = 0.0
    for k in range(n):
        j = (k + 1) % n
        a2 += pu[k] * pv[j] - pu[j] * pv[k]
    if used + n > out_u.shape[0]:
        return -1, 0.5 * abs(a2)
    for k in range(n):
        out_u[used] = pu[k]
        out_v[used] = pv[k]
        out_z[used] = pz[k]
        used += 1
    return used, 0.5 * abs(a2)


@njit(cache=True)
def _grid_patch_points(cx, cy, co, si, quad, post_z, post_origin, post_size, r_off, c_off, pu, pv, pz, ou, ov, oz,
                       out_u, out_v, out_z, used):  # pragma: no cover - compiled
    """``_patch_points`` for a DEM held only as posts: each cell's triangles are made from its
    posts on the fly, as the mesh layout lists them (a full cell split SW-NE into (SW, SE, NE) and
    (SW, NE, NW); a cell with three valid posts the triangle of those three; fewer, nothing).

    ``post_z`` (rows, cols) south row first, NaN at NODATA, is a window whose post [0, 0] is post
    [r_off, c_off] of the grid placed by ``post_origin`` (local x, y of the grid's post [0, 0]).
    Returns (count, covered area); count -1 when the buffer is too small.
    """
    rows = post_z.shape[0]
    cols = post_z.shape[1]
    xmin, xmax, ymin, ymax = _quad_box(cx, cy, co, si, quad)
    ox = post_origin[0]
    oy = post_origin[1]
    dx = post_size[0]
    dy = post_size[1]
    c0 = max(int(np.floor((xmin - ox) / dx)), c_off)
    c1 = min(int(np.floor((xmax - ox) / dx)), c_off + cols - 2)
    r0 = max(int(np.floor((ymin - oy) / dy)), r_off)
    r1 = min(int(np.floor((ymax - oy) / dy)), r_off + rows - 2)
    area = 0.0
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            wr = r - r_off
            wc = c - c_off
            sw = post_z[wr, wc]
            se = post_z[wr, wc + 1]
            ne = post_z[wr + 1, wc + 1]
            nw = post_z[wr + 1, wc]
            xw = ox + c * dx
            xe = ox + (c + 1) * dx
            ys = oy + r * dy
            yn = oy + (r + 1) * dy
            ok_sw = np.isfinite(sw)
            ok_se = np.isfinite(se)
            ok_ne = np.isfinite(ne)
            ok_nw = np.isfinite(nw)
            count = int(ok_sw) + int(ok_se) + int(ok_ne) + int(ok_nw)
            a = 0.0
            if count == 4:
                used, a = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, ys, se, xe, yn, ne, pu, pv, pz, ou,
                                          ov, oz, out_u, out_v, out_z, used)
                area += a
                if used < 0:
                    return -1, area
                used, a = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, yn, ne, xw, yn, nw, pu, pv, pz, ou,
                                          ov, oz, out_u, out_v, out_z, used)
            elif count == 3:
                if not ok_sw:
                    used, a = _append_clipped(cx, cy, co, si, quad, xe, ys, se, xe, yn, ne, xw, yn, nw, pu, pv, pz,
                                              ou, ov, oz, out_u, out_v, out_z, used)
                elif not ok_se:
                    used, a = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, yn, ne, xw, yn, nw, pu, pv, pz,
                                              ou, ov, oz, out_u, out_v, out_z, used)
                elif not ok_ne:
                    used, a = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, ys, se, xw, yn, nw, pu, pv, pz,
                                              ou, ov, oz, out_u, out_v, out_z, used)
                else:
                    used, a = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, ys, se, xe, yn, ne, pu, pv, pz,
                                              ou, ov, oz, out_u, out_v, out_z, used)
            area += a
            if used < 0:
                return -1, area
    return used, area


@njit(cache=True, inline="always")
def _quad_area(quad):  # pragma: no cover - compiled
    a2 = 0.0
    for k in range(4):
        j = (k + 1) % 4
        a2 += quad[k, 0] * quad[j, 1] - quad[j, 0] * quad[k, 1]
    return 0.5 * abs(a2)


@njit(cache=True, inline="always")
def _dem_z(u, v, post_z, r_off, c_off):  # pragma: no cover - compiled
    """Height at post-index coordinates (u, v) inside the raster (the SW-NE split of ``heights_slopes``).

    ``post_z`` may be a window of a larger grid whose post [0, 0] is the grid's post [r_off, c_off]:
    u, v and the cell arithmetic stay in the whole grid's indices, so a result never depends on
    which window it was read through.
    """
    rows = post_z.shape[0]
    cols = post_z.shape[1]
    c = min(max(int(np.floor(u)), c_off), c_off + cols - 2)
    r = min(max(int(np.floor(v)), r_off), r_off + rows - 2)
    fx = u - c
    fy = v - r
    r -= r_off
    c -= c_off
    sw = post_z[r, c]
    ne = post_z[r + 1, c + 1]
    if fx >= fy:
        se = post_z[r, c + 1]
        return sw + fx * (se - sw) + fy * (ne - se)
    nw = post_z[r + 1, c]
    return sw + fy * (nw - sw) + fx * (ne - nw)


@njit(cache=True)
def _dem_patch_points(cx, cy, co, si, quad, post_z, post_origin, post_size, r_off, c_off, out_u, out_v, out_z,
                      used):  # pragma: no cover - compiled
    """The corners of the DEM triangles clipped to one patch, by arithmetic on the grid.

    For a patch lying wholly on full DEM cells these are exactly the points the clipping
    finds: the posts inside the patch, the crossings of the patch's sides with the grid
    lines and cell diagonals, and the patch's corners. Returns the new count, -1 when the
    buffer is too small, or -2 when the patch needs the general path (it reaches past the
    grid or over a NODATA post). ``post_z`` may be a window whose post [0, 0] is post
    [r_off, c_off] of the grid that ``post_origin`` places (see ``_dem_z``).
    """
    rows = post_z.shape[0]
    cols = post_z.shape[1]
    ox = post_origin[0]
    oy = post_origin[1]
    dx = post_size[0]
    dy = post_size[1]
    gu = np.empty(4)
    gv = np.empty(4)
    for k in range(4):
        gu[k] = (cx + co * quad[k, 0] - si * quad[k, 1] - ox) / dx
        gv[k] = (cy + si * quad[k, 0] + co * quad[k, 1] - oy) / dy
        if not (c_off <= gu[k] <= c_off + cols - 1 and r_off <= gv[k] <= r_off + rows - 1):
            return -2
    umin = min(min(gu[0], gu[1]), min(gu[2], gu[3]))
    umax = max(max(gu[0], gu[1]), max(gu[2], gu[3]))
    vmin = min(min(gv[0], gv[1]), min(gv[2], gv[3]))
    vmax = max(max(gv[0], gv[1]), max(gv[2], gv[3]))
    c0 = int(np.floor(umin))
    c1 = min(int(np.ceil(umax)), c_off + cols - 1)
    r0 = int(np.floor(vmin))
    r1 = min(int(np.ceil(vmax)), r_off + rows - 1)
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            if not np.isfinite(post_z[r - r_off, c - c_off]):
                return -2
    # posts inside the patch (the quad is counter-clockwise in the heading frame)
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            px = ox + c * dx - cx
            py = oy + r * dy - cy
            pu = co * px + si * py
            pv = -si * px + co * py
            inside = True
            for k in range(4):
                j = (k + 1) % 4
                ex = quad[j, 0] - quad[k, 0]
                ey = quad[j, 1] - quad[k, 1]
                if ex * (pv - quad[k, 1]) - ey * (pu - quad[k, 0]) < 0.0:
                    inside = False
                    break
            if inside:
                if used >= out_u.shape[0]:
                    return -1
                out_u[used] = pu
                out_v[used] = pv
                out_z[used] = post_z[r - r_off, c - c_off]
                used += 1
    # each side: its corner, then where it crosses grid lines (u, v integer) and diagonals (u - v integer)
    for k in range(4):
        j = (k + 1) % 4
        for family in range(4):
            if family == 0:
                a = 0.0
                b = 0.0
                lo = 0
                hi = 0  # the corner itself: t = 0
            elif family == 1:
                a = gu[k]
                b = gu[j]
            elif family == 2:
                a = gv[k]
                b = gv[j]
            else:
                a = gu[k] - gv[k]
                b = gu[j] - gv[j]
            if family > 0:
                if a == b:
                    continue
                lo = int(np.ceil(min(a, b)))
                hi = int(np.floor(max(a, b)))
            for m in range(lo, hi + 1):
                t = 0.0 if family == 0 else (m - a) / (b - a)
                if family > 0 and not (0.0 < t < 1.0):
                    continue
                qu = quad[k, 0] + t * (quad[j, 0] - quad[k, 0])
                qv = quad[k, 1] + t * (quad[j, 1] - quad[k, 1])
                u = gu[k] + t * (gu[j] - gu[k])
                v = gv[k] + t * (gv[j] - gv[k])
                if used >= out_u.shape[0]:
                    return -1
                out_u[used] = qu
                out_v[used] = qv
                out_z[used] = _dem_z(min(max(u, c_off), c_off + cols - 1.0), min(max(v, r_off), r_off + rows - 1.0),
                                     post_z, r_off, c_off)
                used += 1
    return used


@njit(cache=True, parallel=True)
def footprint_batch(mode, cx, cy, yaw, quads, V, F, plane, origin, size, ny, nx, start, cell_face, listed_once,
                    post_z, post_origin, post_size, planes_in, eps, grid=False, r_off=0, c_off=0,
                    arithmetic=True):  # pragma: no cover - compiled
    """For every pose: mode 0, the lowest supporting plane (a, b, c) over the footprint
    centre; mode 1, the highest ground above ``planes_in`` (signed, m).

    A mesh passes its faces and locator cells (V .. cell_face) and, for a DEM, its posts.
    ``grid`` passes the posts alone (a window of them: see ``_grid_patch_points``), and the
    cells that are not wholly full are clipped from triangles made of their posts;
    ``arithmetic=False`` clips every cell (the oracle the arithmetic is tested against).

    cx, cy : (N,) local footprint centres; yaw : (N,) rad
    quads : (N, 2, 4, 2) the two patches' corners (u, v), counter-clockwise
    Returns (N, 3) planes or (N,) heights, the covered share of the patches (N,), status (N,).
    """
    npose = cx.shape[0]
    dem = post_z.shape[0] >= 2 and post_z.shape[1] >= 2 and arithmetic
    out = np.full((npose, 3), np.nan)
    covered = np.zeros(npose)
    status = np.zeros(npose, np.int64)
    block = 64  # poses per task: the scratch buffers are allocated once per block, not per pose
    for b in prange((npose + block - 1) // block):
        cap = 512
        bu = np.empty(cap)
        bv = np.empty(cap)
        bz = np.empty(cap)
        cand = np.empty(256, np.int64)
        pu = np.empty(MAX_POLY)
        pv = np.empty(MAX_POLY)
        pz = np.empty(MAX_POLY)
        ou = np.empty(MAX_POLY)
        ov = np.empty(MAX_POLY)
        oz = np.empty(MAX_POLY)
        for i in range(b * block, min((b + 1) * block, npose)):
            co = np.cos(yaw[i])
            si = np.sin(yaw[i])
            while True:
                used = 0
                area = 0.0
                for q in range(2):
                    got = -2
                    if dem:
                        got = _dem_patch_points(cx[i], cy[i], co, si, quads[i, q], post_z, post_origin, post_size,
                                                r_off, c_off, bu, bv, bz, used)
                    if got == -2 and grid:  # not wholly on full cells: clip the cells' triangles
                        used, a = _grid_patch_points(cx[i], cy[i], co, si, quads[i, q], post_z, post_origin,
                                                     post_size, r_off, c_off, pu, pv, pz, ou, ov, oz, bu, bv, bz, used)
                    elif got == -2:
                        used, a = _patch_points(cx[i], cy[i], co, si, quads[i, q], V, F, plane, origin, size, ny,
                                                nx, start, cell_face, listed_once, cand, pu, pv, pz, ou, ov, oz,
                                                bu, bv, bz, used)
                    else:
                        used = got
                        a = _quad_area(quads[i, q])
                    area += a
                    if used < 0:
                        break
                if used >= 0:
                    break
                cap *= 4  # a patch over many small triangles: grow the buffers and collect again
                bu = np.empty(cap)
                bv = np.empty(cap)
                bz = np.empty(cap)
            patch_area = _quad_area(quads[i, 0]) + _quad_area(quads[i, 1])
            covered[i] = area / patch_area if patch_area > 0 else 0.0
            if mode == 0:
                a, bb, c, st = support_plane(bu, bv, bz, used, eps)
                out[i, 0] = a
                out[i, 1] = bb
                out[i, 2] = c
                status[i] = st
            else:
                worst = -np.inf
                a = planes_in[i, 0]
                bb = planes_in[i, 1]
                c = planes_in[i, 2]
                for k in range(used):
                    h = bz[k] - (a + bb * bu[k] + c * bv[k])
                    if h > worst:
                        worst = h
                out[i, 0] = worst
                status[i] = 0 if used > 0 else 1
    return out, covered, status
