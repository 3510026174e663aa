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


@njit(cache=True)
def _patch_points(cx, cy, co, si, quad, V, F, plane, origin, size, ny, nx, start, cell_face, listed_once, cand,
                  pu, pv, pz, ou, ov, oz, out_u, out_v, out_z, used):  # pragma: no cover - compiled
    """Append the clipped-triangle corners under one patch; returns (count, covered area).

    cand and pu .. oz are the caller's scratch (cand grows here if too small); listed_once
    says no face is listed in two cells (a DEM's cells), so no sort is needed to skip repeats.
    """
    # world (local) corners and their bounding box
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
        for k in range(3):
            vtx = F[f, k]
            dx = V[vtx, 0] - cx
            dy = V[vtx, 1] - cy
            pu[k] = co * dx + si * dy
            pv[k] = -si * dx + co * dy
            pz[k] = V[vtx, 2]
        n = 3
        for k in range(4):
            n = _clip(pu, pv, pz, n, quad[k, 0], quad[k, 1], quad[(k + 1) % 4, 0], quad[(k + 1) % 4, 1], ou, ov, oz)
            if n == 0:
                break
        if n < 3:
            continue
        a2 = 0.0
        for k in range(n):
            j = (k + 1) % n
            a2 += pu[k] * pv[j] - pu[j] * pv[k]
        area += 0.5 * abs(a2)
        if used + n > out_u.shape[0]:
            return -1, area  # caller grows the buffer and tries again
        for k in range(n):
            out_u[used] = pu[k]
            out_v[used] = pv[k]
            out_z[used] = pz[k]
            used += 1
    return used, area


@njit(cache=True, parallel=True)
def footprint_batch(mode, cx, cy, yaw, quads, V, F, plane, origin, size, ny, nx, start, cell_face, listed_once,
                    planes_in, eps):  # pragma: no cover - compiled
    """For every pose: mode 0, the lowest supporting plane (a, b, c) over the footprint
    centre; mode 1, the highest ground above ``planes_in`` (signed, m).

    cx, cy : (N,) local footprint centres; yaw : (N,) rad
    quads : (N, 2, 4, 2) the two patches' corners (u, v), counter-clockwise
    Returns (N, 3) planes or (N,) heights, the covered share of the patches (N,), status (N,).
    """
    npose = cx.shape[0]
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
                    used, a = _patch_points(cx[i], cy[i], co, si, quads[i, q], V, F, plane, origin, size, ny, nx,
                                            start, cell_face, listed_once, cand, pu, pv, pz, ou, ov, oz,
                                            bu, bv, bz, used)
                    area += a
                    if used < 0:
                        break
                if used >= 0:
                    break
                cap *= 4  # a patch over many small triangles: grow the buffers and collect again
                bu = np.empty(cap)
                bv = np.empty(cap)
                bz = np.empty(cap)
            patch_area = 0.0
            for q in range(2):
                a2 = 0.0
                for k in range(4):
                    j = (k + 1) % 4
                    a2 += quads[i, q, k, 0] * quads[i, q, j, 1] - quads[i, q, j, 0] * quads[i, q, k, 1]
                patch_area += 0.5 * abs(a2)
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
