"""Compiled kernels of ``tankcd_cli.terrain.footprint`` (see its docstring).

Every helper works on raw pointers into C-contiguous float64 / int64 arrays; ``footprint_batch``
is the Python face. Each thread keeps its own scratch: the clipped corners of a pose's patches
(grown by four when a patch holds more points, and kept grown for its next poses), the
candidate faces of a mesh cell range, and the small polygons of the clipping.
"""

import numpy as np

from cython.parallel cimport parallel, prange
from libc.math cimport cos, fabs, isfinite, isnan, sin, INFINITY, NAN
from libc.stdint cimport int64_t, INT64_MIN
from libc.stdlib cimport free, malloc, qsort

from tankcd_cli.geometry._support_plane cimport support_plane_c, support_plane_from_c

MAX_POLY = 16
# batches of at most this many blocks of poses (under a millisecond of work) run in the calling
# thread: on a busy machine a parallel region's end waits for a descheduled thread far longer
SERIAL_BLOCKS = 8

cdef enum:
    _MAX_POLY = 16
    _BLOCK = 64  # poses per task
    _CAP0 = 512  # first size of a thread's corner buffers
    _CAND0 = 256  # first size of a thread's candidate faces
    _ERR_MEMORY = 1
    _ERR_ZERO_DIVISION = 2


cdef struct Scratch:
    double* bu  # the clipped corners of a pose's patches, cap of them
    double* bv
    double* bz
    Py_ssize_t cap
    int64_t* cand  # candidate faces, ccap of them
    Py_ssize_t ccap
    int err  # _ERR_MEMORY or _ERR_ZERO_DIVISION: stop
    double pu[_MAX_POLY]
    double pv[_MAX_POLY]
    double pz[_MAX_POLY]
    double ou[_MAX_POLY]
    double ov[_MAX_POLY]
    double oz[_MAX_POLY]


cdef struct Mesh:
    const double* V  # (nv, 3)
    const int64_t* F  # (nf, 3)
    const double* plane  # (nf, 3)
    double ox, oy, sx, sy  # locator cells' origin and size
    Py_ssize_t ny, nx
    const int64_t* start
    const int64_t* cell_face
    bint listed_once


cdef struct Posts:
    const double* z  # (rows, cols) a window of the grid's posts
    Py_ssize_t rows, cols
    double ox, oy, dx, dy  # the grid's post [0, 0] and spacing
    Py_ssize_t r_off, c_off  # the window's post [0, 0] in the grid


cdef struct Job:
    int mode
    double eps
    bint dem
    bint grid
    const double* cx
    const double* cy
    const double* yaw
    const double* quads  # (N, 2, 4, 2)
    const double* planes_in  # (N, 3), read in modes 1 and 2
    double* out  # (N, stride)
    Py_ssize_t stride
    bint warm  # the support walk starts from planes_in's tilt
    double* covered
    int64_t* status
    Mesh mesh
    Posts posts


# Python's min / max: the second argument only when strictly smaller / larger (NaN never wins)
cdef inline double _fmin(double a, double b) noexcept nogil:
    return b if b < a else a


cdef inline double _fmax(double a, double b) noexcept nogil:
    return b if b > a else a


cdef inline Py_ssize_t _imin(Py_ssize_t a, Py_ssize_t b) noexcept nogil:
    return b if b < a else a


cdef inline Py_ssize_t _imax(Py_ssize_t a, Py_ssize_t b) noexcept nogil:
    return b if b > a else a


# int(np.floor(x)) and int(np.ceil(x)) without a libm call (the baseline x86-64 target has no
# rounding instruction): exact for every x in the int64 range; NaN, infinities and values
# beyond give INT64_MIN, what x86's truncating conversion gives there (a plain C cast is
# undefined for them), and the pass finds no ground under such poses.
cdef inline Py_ssize_t _ifloor(double x) noexcept nogil:
    cdef Py_ssize_t i
    if not (x >= -9223372036854775808.0 and x < 9223372036854775808.0):
        return INT64_MIN
    i = <Py_ssize_t>x
    return i - <Py_ssize_t>(i > x)  # no branch: x is often a grid line, either side by an ulp


cdef inline Py_ssize_t _ifloor_in_range(double x) noexcept nogil:
    """``_ifloor`` for an x known to be finite and inside the grid (clamped to it)."""
    cdef Py_ssize_t i = <Py_ssize_t>x
    return i - <Py_ssize_t>(i > x)


cdef inline Py_ssize_t _iceil(double x) noexcept nogil:
    cdef Py_ssize_t i
    if not (x >= -9223372036854775808.0 and x < 9223372036854775808.0):
        return INT64_MIN
    i = <Py_ssize_t>x
    return i + <Py_ssize_t>(i < x)


cdef int _cmp_i64(const void* x, const void* y) noexcept nogil:
    cdef int64_t a = (<const int64_t*>x)[0]
    cdef int64_t b = (<const int64_t*>y)[0]
    return (a > b) - (a < b)


cdef inline void _sort_i64(int64_t* a, Py_ssize_t n) noexcept nogil:
    cdef Py_ssize_t i, j
    cdef int64_t key
    if n > 32:
        qsort(a, n, sizeof(int64_t), _cmp_i64)
        return
    for i in range(1, n):
        key = a[i]
        j = i - 1
        while j >= 0 and a[j] > key:
            a[j + 1] = a[j]
            j -= 1
        a[j + 1] = key


cdef inline Py_ssize_t _clip(double* pu, double* pv, double* pz, Py_ssize_t count, double au, double av, double bu,
                             double bv, double* ou, double* ov, double* oz) noexcept nogil:
    """Clip polygon (pu, pv, pz)[:count] to the left of the directed edge a->b.

    Writes the result into (ou, ov, oz) (scratch of MAX_POLY) and copies it back; returns its size.
    """
    cdef Py_ssize_t n = 0
    cdef Py_ssize_t i, j
    cdef double eu = bu - au
    cdef double ev = bv - av
    cdef double si, sj, t
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


cdef inline void _quad_box(double cx, double cy, double co, double si, const double* quad, double* box) noexcept nogil:
    """The bounding box (xmin, xmax, ymin, ymax) of a patch turned by the heading and placed at (cx, cy)."""
    cdef double xmin = INFINITY
    cdef double xmax = -INFINITY
    cdef double ymin = INFINITY
    cdef double ymax = -INFINITY
    cdef double wx, wy
    cdef Py_ssize_t k
    for k in range(4):
        wx = cx + co * quad[2 * k] - si * quad[2 * k + 1]
        wy = cy + si * quad[2 * k] + co * quad[2 * k + 1]
        xmin = _fmin(xmin, wx)
        xmax = _fmax(xmax, wx)
        ymin = _fmin(ymin, wy)
        ymax = _fmax(ymax, wy)
    box[0] = xmin
    box[1] = xmax
    box[2] = ymin
    box[3] = ymax


cdef inline Py_ssize_t _append_clipped(double cx, double cy, double co, double si, const double* quad,
                                       double x0, double y0, double z0, double x1, double y1, double z1,
                                       double x2, double y2, double z2, Scratch* sc, Py_ssize_t used,
                                       double* area) noexcept nogil:
    """Clip one triangle (local x, y, z corners) to the patch and append the corners to the
    scratch's buffer; returns the new count or -1 when the buffer is too small (the clipped
    area goes to ``area``)."""
    cdef double* pu = sc.pu
    cdef double* pv = sc.pv
    cdef double* pz = sc.pz
    cdef double dx, dy, a2
    cdef Py_ssize_t n, k, j
    dx = x0 - cx
    dy = y0 - cy
    pu[0] = co * dx + si * dy
    pv[0] = -si * dx + co * dy
    pz[0] = z0
    dx = x1 - cx
    dy = y1 - cy
    pu[1] = co * dx + si * dy
    pv[1] = -si * dx + co * dy
    pz[1] = z1
    dx = x2 - cx
    dy = y2 - cy
    pu[2] = co * dx + si * dy
    pv[2] = -si * dx + co * dy
    pz[2] = z2
    n = 3
    for k in range(4):
        j = (k + 1) % 4
        n = _clip(pu, pv, pz, n, quad[2 * k], quad[2 * k + 1], quad[2 * j], quad[2 * j + 1], sc.ou, sc.ov, sc.oz)
        if n == 0:
            break
    if n < 3:
        area[0] = 0.0
        return used
    a2 = 0.0
    for k in range(n):
        j = (k + 1) % n
        a2 += pu[k] * pv[j] - pu[j] * pv[k]
    area[0] = 0.5 * fabs(a2)
    if used + n > sc.cap:
        return -1
    for k in range(n):
        sc.bu[used] = pu[k]
        sc.bv[used] = pv[k]
        sc.bz[used] = pz[k]
        used += 1
    return used


cdef Py_ssize_t _patch_points(double cx, double cy, double co, double si, const double* quad, const Mesh* m,
                              Scratch* sc, Py_ssize_t used, double* area_out) noexcept nogil:
    """Append the clipped-triangle corners under one patch; returns the count (-1: the buffer is
    too small, or ``sc.err`` is set) and writes the covered area.

    The candidate faces go to the scratch (grown here if too small); ``listed_once`` says no
    face is listed in two cells (a DEM's cells), so no sort is needed to skip repeats.
    """
    cdef double box[4]
    cdef Py_ssize_t c0, c1, r0, r1, r, c, cell, s, t, total, nx = m.nx
    cdef int64_t f, i, j, k
    cdef int64_t* cand
    cdef double area, a
    cdef const double* V = m.V
    if m.sx == 0.0 or m.sy == 0.0:
        sc.err = _ERR_ZERO_DIVISION
        area_out[0] = 0.0
        return -1
    _quad_box(cx, cy, co, si, quad, box)
    c0 = _imax(_ifloor((box[0] - m.ox) / m.sx), 0)
    c1 = _imin(_ifloor((box[1] - m.ox) / m.sx), nx - 1)
    r0 = _imax(_ifloor((box[2] - m.oy) / m.sy), 0)
    r1 = _imin(_ifloor((box[3] - m.oy) / m.sy), m.ny - 1)
    if c0 > c1 or r0 > r1:
        area_out[0] = 0.0
        return used
    total = 0
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            total += m.start[r * nx + c + 1] - m.start[r * nx + c]
    if total > sc.ccap:
        free(sc.cand)
        sc.cand = <int64_t*>malloc(total * sizeof(int64_t))
        if sc.cand == NULL:
            sc.ccap = 0
            sc.err = _ERR_MEMORY
            area_out[0] = 0.0
            return -1
        sc.ccap = total
    cand = sc.cand
    t = 0
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            cell = r * nx + c
            for s in range(m.start[cell], m.start[cell + 1]):
                cand[t] = m.cell_face[s]
                t += 1
    if not m.listed_once:
        _sort_i64(cand, total)
    area = 0.0
    for s in range(total):
        f = cand[s]
        if not m.listed_once and s > 0 and f == cand[s - 1]:
            continue  # a triangle listed in several cells
        if isnan(m.plane[3 * f + 1]):
            continue
        i = m.F[3 * f]
        j = m.F[3 * f + 1]
        k = m.F[3 * f + 2]
        used = _append_clipped(cx, cy, co, si, quad, V[3 * i], V[3 * i + 1], V[3 * i + 2], V[3 * j], V[3 * j + 1],
                               V[3 * j + 2], V[3 * k], V[3 * k + 1], V[3 * k + 2], sc, used, &a)
        area += a
        if used < 0:
            area_out[0] = area
            return -1  # caller grows the buffer and tries again
    area_out[0] = area
    return used


cdef Py_ssize_t _grid_patch_points(double cx, double cy, double co, double si, const double* quad, const Posts* g,
                                   Scratch* sc, Py_ssize_t used, double* area_out) noexcept nogil:
    """``_patch_points`` for a DEM held only as posts: each cell's triangles are made from its
    posts on the fly, as the mesh layout lists them (a full cell split SW-NE into (SW, SE, NE) and
    (SW, NE, NW); a cell with three valid posts the triangle of those three; fewer, nothing).

    ``g.z`` (rows, cols) south row first, NaN at NODATA, is a window whose post [0, 0] is post
    [r_off, c_off] of the grid placed by the grid origin (local x, y of the grid's post [0, 0]).
    Returns the count (-1 when the buffer is too small or ``sc.err`` is set) and writes the area.
    """
    cdef Py_ssize_t rows = g.rows, cols = g.cols, r_off = g.r_off, c_off = g.c_off
    cdef double ox = g.ox, oy = g.oy, dx = g.dx, dy = g.dy
    cdef const double* z = g.z
    cdef double box[4]
    cdef Py_ssize_t c0, c1, r0, r1, r, c, wr, wc, count
    cdef double sw, se, ne, nw, xw, xe, ys, yn, a, area
    cdef bint ok_sw, ok_se, ok_ne, ok_nw
    if dx == 0.0 or dy == 0.0:
        sc.err = _ERR_ZERO_DIVISION
        area_out[0] = 0.0
        return -1
    _quad_box(cx, cy, co, si, quad, box)
    c0 = _imax(_ifloor((box[0] - ox) / dx), c_off)
    c1 = _imin(_ifloor((box[1] - ox) / dx), c_off + cols - 2)
    r0 = _imax(_ifloor((box[2] - oy) / dy), r_off)
    r1 = _imin(_ifloor((box[3] - oy) / dy), r_off + rows - 2)
    area = 0.0
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            wr = r - r_off
            wc = c - c_off
            sw = z[wr * cols + wc]
            se = z[wr * cols + wc + 1]
            ne = z[(wr + 1) * cols + wc + 1]
            nw = z[(wr + 1) * cols + wc]
            xw = ox + c * dx
            xe = ox + (c + 1) * dx
            ys = oy + r * dy
            yn = oy + (r + 1) * dy
            ok_sw = isfinite(sw)
            ok_se = isfinite(se)
            ok_ne = isfinite(ne)
            ok_nw = isfinite(nw)
            count = <Py_ssize_t>ok_sw + <Py_ssize_t>ok_se + <Py_ssize_t>ok_ne + <Py_ssize_t>ok_nw
            a = 0.0
            if count == 4:
                used = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, ys, se, xe, yn, ne, sc, used, &a)
                area += a
                if used < 0:
                    area_out[0] = area
                    return -1
                used = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, yn, ne, xw, yn, nw, sc, used, &a)
            elif count == 3:
                if not ok_sw:
                    used = _append_clipped(cx, cy, co, si, quad, xe, ys, se, xe, yn, ne, xw, yn, nw, sc, used, &a)
                elif not ok_se:
                    used = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, yn, ne, xw, yn, nw, sc, used, &a)
                elif not ok_ne:
                    used = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, ys, se, xw, yn, nw, sc, used, &a)
                else:
                    used = _append_clipped(cx, cy, co, si, quad, xw, ys, sw, xe, ys, se, xe, yn, ne, sc, used, &a)
            area += a
            if used < 0:
                area_out[0] = area
                return -1
    area_out[0] = area
    return used


cdef inline double _quad_area(const double* quad) noexcept nogil:
    cdef double a2 = 0.0
    cdef Py_ssize_t k, j
    for k in range(4):
        j = (k + 1) % 4
        a2 += quad[2 * k] * quad[2 * j + 1] - quad[2 * j] * quad[2 * k + 1]
    return 0.5 * fabs(a2)


cdef inline double _dem_z(double u, double v, const Posts* g) noexcept nogil:
    """Height at post-index coordinates (u, v) inside the raster (the SW-NE split of ``heights_slopes``);
    the caller clamps u, v to the raster, so they are finite.

    ``g.z`` may be a window of a larger grid whose post [0, 0] is the grid's post [r_off, c_off]:
    u, v and the cell arithmetic stay in the whole grid's indices, so a result never depends on
    which window it was read through.
    """
    cdef Py_ssize_t cols = g.cols, r_off = g.r_off, c_off = g.c_off
    cdef Py_ssize_t c = _imin(_imax(_ifloor_in_range(u), c_off), c_off + cols - 2)
    cdef Py_ssize_t r = _imin(_imax(_ifloor_in_range(v), r_off), r_off + g.rows - 2)
    cdef double fx = u - c
    cdef double fy = v - r
    cdef const double* p = g.z + (r - r_off) * cols + (c - c_off)
    cdef double sw = p[0]
    cdef double se = p[1]
    cdef double nw = p[cols]
    cdef double ne = p[cols + 1]
    # both triangles' values, then the one (u, v) lies in: no hard-to-predict branch
    cdef double lower = sw + fx * (se - sw) + fy * (ne - se)
    cdef double upper = sw + fy * (nw - sw) + fx * (ne - nw)
    return lower if fx >= fy else upper


cdef inline Py_ssize_t _side_point(double t, double qku, double qkv, double qju, double qjv, double guk,
                                   double gvk, double guj, double gvj, const Posts* g, Scratch* sc,
                                   Py_ssize_t used) noexcept nogil:
    """Append the point at ``t`` along a patch side (k -> j; heading frame q, post indices g);
    returns the new count or -1 when the buffer is full."""
    cdef double u, v
    if used >= sc.cap:
        return -1
    sc.bu[used] = qku + t * (qju - qku)
    sc.bv[used] = qkv + t * (qjv - qkv)
    u = guk + t * (guj - guk)
    v = gvk + t * (gvj - gvk)
    sc.bz[used] = _dem_z(_fmin(_fmax(u, <double>g.c_off), g.c_off + g.cols - 1.0),
                         _fmin(_fmax(v, <double>g.r_off), g.r_off + g.rows - 1.0), g)
    return used + 1


cdef inline Py_ssize_t _side_crossings(double a, double b, double qku, double qkv, double qju, double qjv,
                                       double guk, double gvk, double guj, double gvj, const Posts* g, Scratch* sc,
                                       Py_ssize_t used) noexcept nogil:
    """Append where a side crosses the integer levels of a quantity going from a to b along it
    (strictly between its ends); returns the new count or -1 when the buffer is full."""
    cdef Py_ssize_t lo, hi, m
    cdef double t
    if a == b:
        return used
    lo = _iceil(_fmin(a, b))
    hi = _ifloor(_fmax(a, b))
    for m in range(lo, hi + 1):
        t = (m - a) / (b - a)
        if not (0.0 < t < 1.0):
            continue
        used = _side_point(t, qku, qkv, qju, qjv, guk, gvk, guj, gvj, g, sc, used)
        if used < 0:
            return -1
    return used


cdef Py_ssize_t _dem_patch_points(double cx, double cy, double co, double si, const double* quad, const Posts* g,
                                  Scratch* sc, Py_ssize_t used) noexcept nogil:
    """The corners of the DEM triangles clipped to one patch, by arithmetic on the grid.

    For a patch lying wholly on full DEM cells these are exactly the points the clipping
    finds: the posts inside the patch, the crossings of the patch's sides with the grid
    lines and cell diagonals, and the patch's corners. Returns the new count, -1 when the
    buffer is too small (or ``sc.err`` is set), or -2 when the patch needs the general path
    (it reaches past the grid or over a NODATA post). ``g.z`` may be a window whose post
    [0, 0] is post [r_off, c_off] of the grid (see ``_dem_z``).
    """
    cdef Py_ssize_t rows = g.rows, cols = g.cols, r_off = g.r_off, c_off = g.c_off
    cdef double ox = g.ox, oy = g.oy, dx = g.dx, dy = g.dy
    cdef const double* z = g.z
    cdef const double* zrow
    cdef double gu[4]
    cdef double gv[4]
    cdef double qu[4]  # the corners and sides, held locally (the buffers' stores cannot change them)
    cdef double qv[4]
    cdef double ex[4]
    cdef double ey[4]
    cdef Py_ssize_t k, j, r, c, c0, c1, r0, r1
    cdef double umin, umax, vmin, vmax, px, py, pu, pv, zp
    cdef bint inside, full = False
    if dx == 0.0 or dy == 0.0:
        sc.err = _ERR_ZERO_DIVISION
        return -1
    for k in range(4):
        qu[k] = quad[2 * k]
        qv[k] = quad[2 * k + 1]
    for k in range(4):
        gu[k] = (cx + co * qu[k] - si * qv[k] - ox) / dx
        gv[k] = (cy + si * qu[k] + co * qv[k] - oy) / dy
        if not (c_off <= gu[k] <= c_off + cols - 1 and r_off <= gv[k] <= r_off + rows - 1):
            return -2
    umin = _fmin(_fmin(gu[0], gu[1]), _fmin(gu[2], gu[3]))
    umax = _fmax(_fmax(gu[0], gu[1]), _fmax(gu[2], gu[3]))
    vmin = _fmin(_fmin(gv[0], gv[1]), _fmin(gv[2], gv[3]))
    vmax = _fmax(_fmax(gv[0], gv[1]), _fmax(gv[2], gv[3]))
    c0 = _ifloor(umin)
    c1 = _imin(_iceil(umax), c_off + cols - 1)
    r0 = _ifloor(vmin)
    r1 = _imin(_iceil(vmax), r_off + rows - 1)
    for k in range(4):
        j = (k + 1) % 4
        ex[k] = qu[j] - qu[k]
        ey[k] = qv[j] - qv[k]
    # posts inside the patch (the quad is counter-clockwise in the heading frame); one NODATA
    # post in the box sends the patch to the general path, whether or not the buffer is full
    for r in range(r0, r1 + 1):
        zrow = z + (r - r_off) * cols
        py = oy + r * dy - cy
        for c in range(c0, c1 + 1):
            zp = zrow[c - c_off]
            if not isfinite(zp):
                return -2
            px = ox + c * dx - cx
            pu = co * px + si * py
            pv = -si * px + co * py
            # inside unless right of a side; the long sides (0 and 2 of a track's patch) first,
            # as most posts of the box that are outside are outside those (the answer is the same)
            if ex[0] * (pv - qv[0]) - ey[0] * (pu - qu[0]) < 0.0:
                continue
            if ex[2] * (pv - qv[2]) - ey[2] * (pu - qu[2]) < 0.0:
                continue
            inside = ((not (ex[1] * (pv - qv[1]) - ey[1] * (pu - qu[1]) < 0.0))
                      & (not (ex[3] * (pv - qv[3]) - ey[3] * (pu - qu[3]) < 0.0)))
            if inside:
                if used >= sc.cap:
                    full = True
                    continue
                sc.bu[used] = pu
                sc.bv[used] = pv
                sc.bz[used] = zp
                used += 1
    if full:
        return -1
    # each side: its corner, then where it crosses grid lines (u, v integer) and diagonals (u - v integer)
    for k in range(4):
        j = (k + 1) % 4
        used = _side_point(0.0, qu[k], qv[k], qu[j], qv[j], gu[k], gv[k], gu[j], gv[j], g, sc, used)
        if used < 0:
            return -1
        used = _side_crossings(gu[k], gu[j], qu[k], qv[k], qu[j], qv[j], gu[k], gv[k], gu[j], gv[j], g, sc, used)
        if used < 0:
            return -1
        used = _side_crossings(gv[k], gv[j], qu[k], qv[k], qu[j], qv[j], gu[k], gv[k], gu[j], gv[j], g, sc, used)
        if used < 0:
            return -1
        used = _side_crossings(gu[k] - gv[k], gu[j] - gv[j], qu[k], qv[k], qu[j], qv[j], gu[k], gv[k], gu[j], gv[j],
                               g, sc, used)
        if used < 0:
            return -1
    return used


cdef Scratch* _scratch_new() noexcept nogil:
    cdef Scratch* sc = <Scratch*>malloc(sizeof(Scratch))
    if sc == NULL:
        return NULL
    sc.cap = _CAP0
    sc.ccap = _CAND0
    sc.err = 0
    sc.bu = <double*>malloc(_CAP0 * sizeof(double))
    sc.bv = <double*>malloc(_CAP0 * sizeof(double))
    sc.bz = <double*>malloc(_CAP0 * sizeof(double))
    sc.cand = <int64_t*>malloc(_CAND0 * sizeof(int64_t))
    if sc.bu == NULL or sc.bv == NULL or sc.bz == NULL or sc.cand == NULL:
        sc.err = _ERR_MEMORY
    return sc


cdef void _scratch_free(Scratch* sc) noexcept nogil:
    if sc != NULL:
        free(sc.bu)
        free(sc.bv)
        free(sc.bz)
        free(sc.cand)
        free(sc)


cdef bint _grow(Scratch* sc) noexcept nogil:
    """A patch over many small triangles: four times the corner buffers (their contents are not kept)."""
    free(sc.bu)
    free(sc.bv)
    free(sc.bz)
    sc.cap *= 4
    sc.bu = <double*>malloc(sc.cap * sizeof(double))
    sc.bv = <double*>malloc(sc.cap * sizeof(double))
    sc.bz = <double*>malloc(sc.cap * sizeof(double))
    if sc.bu == NULL or sc.bv == NULL or sc.bz == NULL:
        sc.err = _ERR_MEMORY
        return False
    return True


cdef void _block(const Job* jb, Scratch* sc, Py_ssize_t lo, Py_ssize_t hi) noexcept nogil:
    """Poses lo .. hi - 1 with one thread's scratch; stops at an error (``sc.err``)."""
    cdef Py_ssize_t i, q, k, used, got
    cdef double co, si, area, a, patch_area, worst, h, pa, pb, pc
    cdef const double* quad
    cdef double pl[3]
    cdef int st
    for i in range(lo, hi):
        co = cos(jb.yaw[i])
        si = sin(jb.yaw[i])
        while True:
            used = 0
            area = 0.0
            for q in range(2):
                quad = jb.quads + 8 * (2 * i + q)
                got = -2
                if jb.dem:
                    got = _dem_patch_points(jb.cx[i], jb.cy[i], co, si, quad, &jb.posts, sc, used)
                if got == -2 and jb.grid:  # not wholly on full cells: clip the cells' triangles
                    used = _grid_patch_points(jb.cx[i], jb.cy[i], co, si, quad, &jb.posts, sc, used, &a)
                elif got == -2:
                    used = _patch_points(jb.cx[i], jb.cy[i], co, si, quad, &jb.mesh, sc, used, &a)
                else:
                    used = got
                    a = _quad_area(quad)
                area += a
                if used < 0:
                    break
            if used >= 0:
                break
            if sc.err or not _grow(sc):  # else a patch over many small triangles: collect again
                return
        quad = jb.quads + 16 * i
        patch_area = _quad_area(quad) + _quad_area(quad + 8)
        jb.covered[i] = area / patch_area if patch_area > 0 else 0.0
        if jb.mode != 1:
            if jb.warm:  # from the given plane's tilt
                st = support_plane_from_c(sc.bu, sc.bv, sc.bz, used, jb.eps, jb.planes_in[3 * i + 1],
                                          jb.planes_in[3 * i + 2], pl)
            else:
                st = support_plane_c(sc.bu, sc.bv, sc.bz, used, jb.eps, pl)
            if st < 0:
                sc.err = _ERR_ZERO_DIVISION
                return
            jb.out[jb.stride * i] = pl[0]
            jb.out[jb.stride * i + 1] = pl[1]
            jb.out[jb.stride * i + 2] = pl[2]
            jb.status[i] = st
        if jb.mode != 0:
            worst = -INFINITY
            pa = jb.planes_in[3 * i]
            pb = jb.planes_in[3 * i + 1]
            pc = jb.planes_in[3 * i + 2]
            for k in range(used):
                h = sc.bz[k] - (pa + pb * sc.bu[k] + pc * sc.bv[k])
                if h > worst:
                    worst = h
            if jb.mode == 1:
                jb.out[jb.stride * i] = worst
                jb.status[i] = 0 if used > 0 else 1
            else:  # the support plane's status stands; no ground under the patches: NaN
                jb.out[jb.stride * i + 3] = worst if used > 0 else NAN


_NO_MESH = (np.zeros((1, 3)), np.zeros((1, 3), np.int64), np.zeros((1, 3)), np.zeros(2), np.ones(2), 0, 0,
            np.zeros(1, np.int64), np.zeros(1, np.int64), True)
_NO_POSTS = (np.empty((0, 0)), np.zeros(2), np.ones(2), 0, 0)


cdef void _raise_for(int err) except *:
    """The Python error for a pass's error code (none for 0)."""
    if err == _ERR_MEMORY:
        raise MemoryError()
    if err == _ERR_ZERO_DIVISION:
        raise ZeroDivisionError("division by zero")


def footprint_batch(mode, cx, cy, yaw, quads, planes_in, eps, mesh, posts, arithmetic=True, warm=False):
    """For every pose: mode 0, the lowest supporting plane (a, b, c) over the footprint
    centre; mode 1, the highest ground above ``planes_in`` (signed, m); mode 2, both from the
    one pass (a, b, c, highest), with the support plane's status.

    mesh : the faces and their locator (``terrain.footprint.MeshGround``), or None for a DEM held
        as posts alone (then cells that are not wholly full are clipped from triangles made of
        their posts)
    posts : a DEM's posts, or a window of them (``terrain.footprint.PostGround``), or None
    arithmetic : read full DEM cells from the posts (False clips every cell: the oracle the
        arithmetic is tested against)
    warm : modes 0 and 2 start the support walk from ``planes_in``'s tilt (fewer pivots when it
        is near the answer; see ``support_plane_from_c``)

    cx, cy : (N,) local footprint centres; yaw : (N,) rad
    quads : (N, 2, 4, 2) the two patches' corners (u, v), counter-clockwise
    Returns (N, 3) planes, or (N, 3) with the heights in column 0 (mode 1), or (N, 4) (mode 2);
    the covered share of the patches (N,); status (N,).
    """
    grid = mesh is None
    V, F, plane, origin, size, ny, nx, start, cell_face, listed_once = _NO_MESH if grid else mesh
    post_z, post_origin, post_size, r_off, c_off = _NO_POSTS if posts is None else posts
    cdef const double[::1] cx_v = np.ascontiguousarray(cx, dtype=np.float64)
    cdef const double[::1] cy_v = np.ascontiguousarray(cy, dtype=np.float64)
    cdef const double[::1] yaw_v = np.ascontiguousarray(yaw, dtype=np.float64)
    cdef const double[:, :, :, ::1] quads_v = np.ascontiguousarray(quads, dtype=np.float64)
    cdef const double[:, ::1] V_v = np.ascontiguousarray(V, dtype=np.float64)
    cdef const int64_t[:, ::1] F_v = np.ascontiguousarray(F, dtype=np.int64)
    cdef const double[:, ::1] plane_v = np.ascontiguousarray(plane, dtype=np.float64)
    cdef const double[::1] origin_v = np.ascontiguousarray(origin, dtype=np.float64)
    cdef const double[::1] size_v = np.ascontiguousarray(size, dtype=np.float64)
    cdef const int64_t[::1] start_v = np.ascontiguousarray(start, dtype=np.int64)
    cdef const int64_t[::1] cell_face_v = np.ascontiguousarray(cell_face, dtype=np.int64)
    cdef const double[:, ::1] post_z_v = np.ascontiguousarray(post_z, dtype=np.float64)
    cdef const double[::1] post_origin_v = np.ascontiguousarray(post_origin, dtype=np.float64)
    cdef const double[::1] post_size_v = np.ascontiguousarray(post_size, dtype=np.float64)
    cdef const double[:, ::1] planes_in_v = np.ascontiguousarray(planes_in, dtype=np.float64)
    cdef Py_ssize_t npose = cx_v.shape[0]
    cdef Job job
    if cy_v.shape[0] < npose or yaw_v.shape[0] < npose or quads_v.shape[0] < npose:
        raise ValueError("cy, yaw and quads need a row for every pose")
    if quads_v.shape[1] != 2 or quads_v.shape[2] != 4 or quads_v.shape[3] != 2:
        raise ValueError("quads must be (N, 2, 4, 2)")
    if (mode != 0 or warm) and (planes_in_v.shape[0] < npose or planes_in_v.shape[1] < 3):
        raise ValueError("planes_in must be (N, 3)")
    out_arr = np.full((npose, 4 if mode == 2 else 3), np.nan)
    covered_arr = np.zeros(npose)
    status_arr = np.zeros(npose, np.int64)
    if npose == 0:
        return out_arr, covered_arr, status_arr
    cdef double[:, ::1] out_v = out_arr
    cdef double[::1] covered_v = covered_arr
    cdef int64_t[::1] status_v = status_arr
    if mode not in (0, 1, 2):
        raise ValueError(f"mode must be 0, 1 or 2, not {mode!r}")
    job.mode = mode
    job.stride = out_v.shape[1]
    job.warm = bool(warm)
    job.eps = eps
    job.dem = post_z_v.shape[0] >= 2 and post_z_v.shape[1] >= 2 and bool(arithmetic)
    job.grid = bool(grid)
    job.cx = &cx_v[0]
    job.cy = &cy_v[0]
    job.yaw = &yaw_v[0]
    job.quads = &quads_v[0, 0, 0, 0]
    job.planes_in = &planes_in_v[0, 0]
    job.out = &out_v[0, 0]
    job.covered = &covered_v[0]
    job.status = &status_v[0]
    job.mesh.V = &V_v[0, 0]
    job.mesh.F = &F_v[0, 0]
    job.mesh.plane = &plane_v[0, 0]
    job.mesh.ox = origin_v[0]
    job.mesh.oy = origin_v[1]
    job.mesh.sx = size_v[0]
    job.mesh.sy = size_v[1]
    job.mesh.ny = ny
    job.mesh.nx = nx
    job.mesh.start = &start_v[0]
    job.mesh.cell_face = &cell_face_v[0]
    job.mesh.listed_once = bool(listed_once)
    job.posts.z = &post_z_v[0, 0]
    job.posts.rows = post_z_v.shape[0]
    job.posts.cols = post_z_v.shape[1]
    job.posts.ox = post_origin_v[0]
    job.posts.oy = post_origin_v[1]
    job.posts.dx = post_size_v[0]
    job.posts.dy = post_size_v[1]
    job.posts.r_off = r_off
    job.posts.c_off = c_off
    cdef Py_ssize_t nblock = (npose + _BLOCK - 1) // _BLOCK
    cdef Py_ssize_t blk
    cdef Scratch* sc
    cdef int err = 0
    cdef int* err_ptr = &err
    sc = NULL
    if nblock <= SERIAL_BLOCKS:
        # a few tasks: run here (SERIAL_BLOCKS; the reference's late rounds are this size)
        with nogil:
            sc = _scratch_new()
            if sc == NULL:
                err = _ERR_MEMORY
            else:
                if not sc.err:  # its buffers allocated
                    _block(&job, sc, 0, npose)
                err = sc.err
            _scratch_free(sc)
        _raise_for(err)
        return out_arr, covered_arr, status_arr
    with nogil, parallel():
        sc = _scratch_new()
        for blk in prange(nblock, schedule="dynamic"):
            if sc == NULL:
                err_ptr[0] = _ERR_MEMORY
            elif not sc.err:
                _block(&job, sc, blk * _BLOCK, _imin((blk + 1) * _BLOCK, npose))
                if sc.err:
                    err_ptr[0] = sc.err
        _scratch_free(sc)
    _raise_for(err)
    return out_arr, covered_arr, status_arr
