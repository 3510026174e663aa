"""Height and class queries on a DEM held only as posts, compiled ahead of time (Cython).

See :mod:`tankcd_cli.terrain.grid.post_queries` for the surface and the window convention; a
full cell's height and slope come from ``_post_cell.pxd``, the arithmetic the mesh layout's
kernels use on a DEM's cells, so both layouts give the same bits there.
"""

from cython.parallel cimport prange
from libc.math cimport cos, isfinite, sin, INFINITY, NAN
from libc.stdint cimport uint8_t

import numpy as np

from tankcd_cli.geometry.arrays import f64 as _f64, pair as _pair

from tankcd_cli.terrain._post_cell cimport cell_from_posts, full_cell_c, ifloor

BARY_EPS = 1e-9  # as the mesh locator: points this close (barycentric units) to an edge count as inside
cdef double _BARY_EPS = 1e-9


# --- helpers ---------------------------------------------------------------------------------

cdef inline bint _triangle(double ux, double uy, double uz, double vx, double vy, double vz,
                           double wx, double wy, double wz, double fx, double fy, double dx, double dy,
                           double* z, double* gx, double* gy) noexcept nogil:
    """Height and gradient of the plane through three cell-fraction points at (fx, fy); returns
    whether (fx, fy) lies in their triangle (with BARY_EPS)."""
    cdef double e1x = vx - ux
    cdef double e1y = vy - uy
    cdef double e2x = wx - ux
    cdef double e2y = wy - uy
    cdef double det = e1x * e2y - e1y * e2x
    cdef double px = fx - ux
    cdef double py = fy - uy
    cdef double l1 = (px * e2y - py * e2x) / det
    cdef double l2 = (e1x * py - e1y * px) / det
    cdef bint inside = l1 >= -_BARY_EPS and l2 >= -_BARY_EPS and l1 + l2 <= 1.0 + _BARY_EPS
    # plane z = uz + a fx + b fy in cell units, then per metre
    cdef double a = ((vz - uz) * e2y - (wz - uz) * e1y) / det
    cdef double b = (e1x * (wz - uz) - e2x * (vz - uz)) / det
    z[0] = uz + a * px + b * py
    gx[0] = a / dx
    gy[0] = b / dy
    return inside


cdef inline void _nan3(double* z, double* gx, double* gy) noexcept nogil:
    z[0] = NAN
    gx[0] = NAN
    gy[0] = NAN


cdef void _partial_cell(const double* post_z, Py_ssize_t rows, Py_ssize_t cols, Py_ssize_t r, Py_ssize_t c,
                        Py_ssize_t r_off, Py_ssize_t c_off, double fx, double fy, double dx, double dy,
                        double* z, double* gx, double* gy) noexcept nogil:
    """Height and gradient at (fx, fy) in cell (r, c) (whole-grid indices) when the cell has
    exactly three valid posts and the point is in their triangle; NaN otherwise."""
    cdef Py_ssize_t wr = r - r_off
    cdef Py_ssize_t wc = c - c_off
    cdef bint inside
    if wr < 0 or wc < 0 or wr > rows - 2 or wc > cols - 2:
        _nan3(z, gx, gy)
        return
    cdef const double* south = post_z + wr * cols + wc
    cdef double sw = south[0]
    cdef double se = south[1]
    cdef double ne = south[cols + 1]
    cdef double nw = south[cols]
    cdef bint ok_sw = isfinite(sw)
    cdef bint ok_se = isfinite(se)
    cdef bint ok_ne = isfinite(ne)
    cdef bint ok_nw = isfinite(nw)
    cdef int count = <int>ok_sw + <int>ok_se + <int>ok_ne + <int>ok_nw
    if count == 4:
        # a full cell reached from a neighbour (a point on the shared border)
        if fx >= fy:
            inside = _triangle(0.0, 0.0, sw, 1.0, 0.0, se, 1.0, 1.0, ne, fx, fy, dx, dy, z, gx, gy)
        else:
            inside = _triangle(0.0, 0.0, sw, 1.0, 1.0, ne, 0.0, 1.0, nw, fx, fy, dx, dy, z, gx, gy)
    elif count == 3:
        if not ok_sw:
            inside = _triangle(1.0, 0.0, se, 1.0, 1.0, ne, 0.0, 1.0, nw, fx, fy, dx, dy, z, gx, gy)
        elif not ok_se:
            inside = _triangle(0.0, 0.0, sw, 1.0, 1.0, ne, 0.0, 1.0, nw, fx, fy, dx, dy, z, gx, gy)
        elif not ok_ne:
            inside = _triangle(0.0, 0.0, sw, 1.0, 0.0, se, 0.0, 1.0, nw, fx, fy, dx, dy, z, gx, gy)
        else:
            inside = _triangle(0.0, 0.0, sw, 1.0, 0.0, se, 1.0, 1.0, ne, fx, fy, dx, dy, z, gx, gy)
    else:
        _nan3(z, gx, gy)
        return
    if not inside:
        _nan3(z, gx, gy)


cdef void _grid_height_one(double x, double y, const double* post_z, Py_ssize_t rows, Py_ssize_t cols,
                           double ox, double oy, double dx, double dy, Py_ssize_t r_off, Py_ssize_t c_off,
                           Py_ssize_t grid_rows, Py_ssize_t grid_cols,
                           double* z, double* gx, double* gy) noexcept nogil:
    if not (isfinite(x) and isfinite(y)):
        _nan3(z, gx, gy)
        return
    cdef double u = (x - ox) / dx
    cdef double v = (y - oy) / dy
    cdef Py_ssize_t c = ifloor(u)
    cdef Py_ssize_t r = ifloor(v)
    cdef Py_ssize_t wr, wc, dr, dc
    cdef double best, bx, by, cz, cgx, cgy
    if c == grid_cols - 1 and u <= <double>(grid_cols - 1) + 1e-9:
        c = grid_cols - 2
    if r == grid_rows - 1 and v <= <double>(grid_rows - 1) + 1e-9:
        r = grid_rows - 2
    if c < -1 or r < -1 or c > grid_cols - 1 or r > grid_rows - 1:
        _nan3(z, gx, gy)
        return
    wr = r - r_off
    wc = c - c_off
    if 0 <= wr <= rows - 2 and 0 <= wc <= cols - 2:
        full_cell_c(post_z, cols, wr, wc, u - <double>c, v - <double>r, dx, dy, z, gx, gy)
        if isfinite(z[0]):
            return
    # a cell with a missing post, or a point just outside a cell: its triangle, then the
    # neighbours' (a point on a cell border may lie only in a neighbour's triangle)
    _partial_cell(post_z, rows, cols, r, c, r_off, c_off, u - <double>c, v - <double>r, dx, dy, z, gx, gy)
    if isfinite(z[0]):
        return
    best = -INFINITY
    bx = NAN
    by = NAN
    for dr in range(-1, 2):
        for dc in range(-1, 2):
            if best == -INFINITY and (dr != 0 or dc != 0):
                _partial_cell(post_z, rows, cols, r + dr, c + dc, r_off, c_off, u - <double>(c + dc),
                              v - <double>(r + dr), dx, dy, &cz, &cgx, &cgy)
                if isfinite(cz):
                    best = cz
                    bx = cgx
                    by = cgy
    if best == -INFINITY:
        _nan3(z, gx, gy)
        return
    z[0] = best
    gx[0] = bx
    gy[0] = by


cdef uint8_t _worst_class_one(double px, double py, double yaw, const double* su, const double* sv, Py_ssize_t m,
                              const uint8_t* classes, Py_ssize_t rows, Py_ssize_t cols, double ox, double oy,
                              double dx, double dy, Py_ssize_t r_off, Py_ssize_t c_off, int top) noexcept nogil:
    """Highest class among the posts nearest to the m sample offsets of one footprint; 255 if none.
    Stops once ``top`` (the highest class there is) is found."""
    cdef double co = cos(yaw)
    cdef double si = sin(yaw)
    cdef int worst = -1
    cdef double fu[64]
    cdef double fv[64]
    cdef Py_ssize_t k0, k, kn, row, col
    cdef uint8_t c
    for k0 in range(0, m, 64):
        kn = m - k0 if m - k0 < 64 else 64
        # the samples' fractional post indices (a loop the compiler vectorizes), then their posts
        for k in range(kn):
            fu[k] = (px + co * su[k0 + k] - si * sv[k0 + k] - ox) / dx + 0.5
            fv[k] = (py + si * su[k0 + k] + co * sv[k0 + k] - oy) / dy + 0.5
        for k in range(kn):
            col = ifloor(fu[k]) - c_off
            row = ifloor(fv[k]) - r_off
            if 0 <= row < rows and 0 <= col < cols:
                c = classes[row * cols + col]
                if c != 255 and c > worst:
                    worst = c
        if worst >= top:  # the highest class: nothing later can raise it
            break
    if worst >= 0:
        return <uint8_t>worst
    return 255


cdef inline const double* _ptr2(const double[:, ::1] a) noexcept nogil:
    if a.shape[0] == 0 or a.shape[1] == 0:
        return NULL
    return &a[0, 0]


# --- Python-level kernels ----------------------------------------------------------------------

def full_cell(post_z, Py_ssize_t wr, Py_ssize_t wc, double fx, double fy, double dx, double dy):
    """Height and gradient at fractions (fx, fy) of cell [wr, wc] of ``post_z`` (south row first)
    when its four posts are valid (the SW-NE split); NaN otherwise."""
    pz = np.asarray(post_z)
    cdef double sw = pz[wr, wc]
    cdef double se = pz[wr, wc + 1]
    cdef double ne = pz[wr + 1, wc + 1]
    cdef double nw = pz[wr + 1, wc]
    cdef double z, gx, gy
    cell_from_posts(sw, se, ne, nw, fx, fy, dx, dy, &z, &gx, &gy)
    return z, gx, gy


def grid_height_one(double x, double y, post_z, post_origin, post_size, Py_ssize_t r_off, Py_ssize_t c_off,
                    Py_ssize_t grid_rows, Py_ssize_t grid_cols):
    """Height and gradient (dz/dx, dz/dy) at one local point; NaN off the terrain.

    grid_rows, grid_cols : the whole grid's size in posts (a point on its far edge belongs
    to the last cell, as in the mesh locator).
    """
    cdef const double[:, ::1] pz = _f64(post_z)
    cdef const double[::1] po = _pair(post_origin, "post_origin")
    cdef const double[::1] ps = _pair(post_size, "post_size")
    cdef double z, gx, gy
    _grid_height_one(x, y, _ptr2(pz), pz.shape[0], pz.shape[1], po[0], po[1], ps[0], ps[1], r_off, c_off,
                     grid_rows, grid_cols, &z, &gx, &gy)
    return z, gx, gy


def grid_heights_slopes(px, py, post_z, post_origin, post_size, Py_ssize_t r_off, Py_ssize_t c_off,
                        Py_ssize_t grid_rows, Py_ssize_t grid_cols):
    """Height and gradient at local points (N,); NaN off the terrain (see ``grid_height_one``)."""
    cdef const double[::1] x = _f64(px)
    cdef const double[::1] y = _f64(py)
    cdef const double[:, ::1] pz = _f64(post_z)
    cdef const double[::1] po = _pair(post_origin, "post_origin")
    cdef const double[::1] ps = _pair(post_size, "post_size")
    cdef Py_ssize_t n = x.shape[0]
    if y.shape[0] < n:
        raise ValueError("py is shorter than px")
    z_arr = np.empty(n)
    gx_arr = np.empty(n)
    gy_arr = np.empty(n)
    cdef double[::1] z = z_arr
    cdef double[::1] gx = gx_arr
    cdef double[::1] gy = gy_arr
    cdef const double* pzp = _ptr2(pz)
    cdef Py_ssize_t rows = pz.shape[0]
    cdef Py_ssize_t cols = pz.shape[1]
    cdef double ox = po[0]
    cdef double oy = po[1]
    cdef double dx = ps[0]
    cdef double dy = ps[1]
    cdef Py_ssize_t i
    for i in prange(n, nogil=True, schedule="static"):
        _grid_height_one(x[i], y[i], pzp, rows, cols, ox, oy, dx, dy, r_off, c_off, grid_rows, grid_cols,
                         &z[i], &gx[i], &gy[i])
    return z_arr, gx_arr, gy_arr


def grid_heights_at_offsets(px, py, yaw, su, sv, post_z, post_origin, post_size, Py_ssize_t r_off,
                            Py_ssize_t c_off, Py_ssize_t grid_rows, Py_ssize_t grid_cols):
    """Heights (N, m) at sample offsets (su, sv) (m,) in each pose's heading frame (local centres
    px, py, headings yaw (N,)): ``grid_heights_slopes`` at those points without forming them in
    memory or computing the slopes' arrays; NaN off the terrain."""
    cdef const double[::1] x = _f64(px)
    cdef const double[::1] y = _f64(py)
    cdef const double[::1] w = _f64(yaw)
    cdef const double[::1] u = _f64(su)
    cdef const double[::1] v = _f64(sv)
    cdef const double[:, ::1] pz = _f64(post_z)
    cdef const double[::1] po = _pair(post_origin, "post_origin")
    cdef const double[::1] ps = _pair(post_size, "post_size")
    cdef Py_ssize_t n = x.shape[0]
    cdef Py_ssize_t m = u.shape[0]
    if y.shape[0] < n or w.shape[0] < n:
        raise ValueError("py and yaw must be as long as px")
    if v.shape[0] < m:
        raise ValueError("sv is shorter than su")
    out_arr = np.empty((n, m))
    if n == 0 or m == 0:
        return out_arr
    cdef double[:, ::1] out = out_arr
    cdef const double* pzp = _ptr2(pz)
    cdef Py_ssize_t rows = pz.shape[0]
    cdef Py_ssize_t cols = pz.shape[1]
    cdef double ox = po[0]
    cdef double oy = po[1]
    cdef double dx = ps[0]
    cdef double dy = ps[1]
    cdef Py_ssize_t i, k
    cdef double co, si, gx, gy
    for i in prange(n, nogil=True, schedule="static"):
        co = cos(w[i])
        si = sin(w[i])
        gx = 0.0  # assigned here so that each thread has its own (the kernel writes them through pointers)
        gy = 0.0
        for k in range(m):
            # the same arithmetic as forming the points first: (x + cos u) - sin v
            _grid_height_one(x[i] + co * u[k] - si * v[k], y[i] + si * u[k] + co * v[k], pzp, rows, cols, ox, oy,
                             dx, dy, r_off, c_off, grid_rows, grid_cols, &out[i, k], &gx, &gy)
    return out_arr


def grid_worst_class(px, py, yaw, su, sv, classes, post_origin, post_size, Py_ssize_t r_off, Py_ssize_t c_off,
                     int top=254):
    """Highest class code among the posts nearest to sample offsets (su, sv) of each footprint
    (local centres px, py, headings yaw); 255 where none is known. ``classes`` is a window
    like ``post_z`` (255 at NODATA); ``top``, the highest code there can be, ends a search early."""
    cdef const double[::1] x = _f64(px)
    cdef const double[::1] y = _f64(py)
    cdef const double[::1] w = _f64(yaw)
    cdef const double[::1] u = _f64(su)
    cdef const double[::1] v = _f64(sv)
    cdef const uint8_t[:, ::1] cls = np.ascontiguousarray(classes, dtype=np.uint8)
    cdef const double[::1] po = _pair(post_origin, "post_origin")
    cdef const double[::1] ps = _pair(post_size, "post_size")
    cdef Py_ssize_t n = x.shape[0]
    cdef Py_ssize_t m = u.shape[0]
    if y.shape[0] < n or w.shape[0] < n:
        raise ValueError("py and yaw must be as long as px")
    if v.shape[0] < m:
        raise ValueError("sv is shorter than su")
    out_arr = np.full(n, 255, np.uint8)
    cdef uint8_t[::1] out = out_arr
    cdef Py_ssize_t rows = cls.shape[0]
    cdef Py_ssize_t cols = cls.shape[1]
    cdef double ox = po[0]
    cdef double oy = po[1]
    cdef double dx = ps[0]
    cdef double dy = ps[1]
    cdef const double* xp = &x[0] if n > 0 else NULL
    cdef const double* yp = &y[0] if n > 0 else NULL
    cdef const double* wp = &w[0] if n > 0 else NULL
    cdef const double* up = &u[0] if m > 0 else NULL
    cdef const double* vp = &v[0] if m > 0 else NULL
    cdef const uint8_t* cp = &cls[0, 0] if rows > 0 and cols > 0 else NULL
    cdef Py_ssize_t i
    for i in prange(n, nogil=True, schedule="static"):
        out[i] = _worst_class_one(xp[i], yp[i], wp[i], up, vp, m, cp, rows, cols, ox, oy, dx, dy, r_off, c_off, top)
    return out_arr


cdef inline bint _box_cells(double px, double py, double yaw, const double* quad, Py_ssize_t k, double ox,
                            double oy, double dx, double dy, Py_ssize_t* span) noexcept nogil:
    """The posts (span: c0, c1, r0, r1, whole-grid indices, not clipped) of every cell the bounding
    box of the corners ``quad`` (k, 2) in one pose's heading frame touches; False where a corner is
    not finite."""
    cdef double co = cos(yaw)
    cdef double si = sin(yaw)
    cdef double xmin = INFINITY
    cdef double xmax = -INFINITY
    cdef double ymin = INFINITY
    cdef double ymax = -INFINITY
    cdef double wx, wy
    cdef Py_ssize_t j
    for j in range(k):
        wx = px + co * quad[2 * j] - si * quad[2 * j + 1]
        wy = py + si * quad[2 * j] + co * quad[2 * j + 1]
        xmin = wx if wx < xmin else xmin
        xmax = wx if wx > xmax else xmax
        ymin = wy if wy < ymin else ymin
        ymax = wy if wy > ymax else ymax
    if not (isfinite(xmin) and isfinite(xmax) and isfinite(ymin) and isfinite(ymax)):
        return False
    span[0] = ifloor((xmin - ox) / dx)
    span[1] = ifloor((xmax - ox) / dx) + 1
    span[2] = ifloor((ymin - oy) / dy)
    span[3] = ifloor((ymax - oy) / dy) + 1
    return True


cdef double _highest_above_plane_one(double px, double py, double yaw, const double* quad, Py_ssize_t k,
                                     double pa, double pb, double pc, const double* post_z, Py_ssize_t rows,
                                     Py_ssize_t cols, double ox, double oy, double dx, double dy,
                                     Py_ssize_t r_off, Py_ssize_t c_off, Py_ssize_t grid_rows,
                                     Py_ssize_t grid_cols) noexcept nogil:
    """Upper bound of (ground - plane) over the polygon corners ``quad`` (k, 2) in the heading
    frame of one pose: the largest (post - plane) over every post of every cell the corners'
    bounding box touches (-inf: no valid post there; +inf: the window does not hold them all)."""
    cdef double co = cos(yaw)
    cdef double si = sin(yaw)
    cdef double z, du, dv, rel, best
    cdef Py_ssize_t r0, r1, c0, c1, r, c
    cdef Py_ssize_t span[4]
    if not _box_cells(px, py, yaw, quad, k, ox, oy, dx, dy, span):
        return NAN
    c0, c1, r0, r1 = span[0], span[1], span[2], span[3]
    # posts of the grid only; every one of them must be in the window
    c0 = c0 if c0 > 0 else 0
    r0 = r0 if r0 > 0 else 0
    c1 = c1 if c1 < grid_cols - 1 else grid_cols - 1
    r1 = r1 if r1 < grid_rows - 1 else grid_rows - 1
    if c0 > c1 or r0 > r1:
        return -INFINITY
    if c0 < c_off or r0 < r_off or c1 - c_off > cols - 1 or r1 - r_off > rows - 1:
        return INFINITY
    best = -INFINITY
    for r in range(r0, r1 + 1):
        dv = oy + <double>r * dy - py
        for c in range(c0, c1 + 1):
            z = post_z[(r - r_off) * cols + (c - c_off)]
            if isfinite(z):
                du = ox + <double>c * dx - px
                # the post in the heading frame: (co du + si dv, -si du + co dv)
                rel = z - (pa + pb * (co * du + si * dv) + pc * (co * dv - si * du))
                best = rel if rel > best else best
    return best


def _plane_query(px, py, yaw, quads, planes, post_z, post_origin, post_size, bint shared_quads):
    """The arrays of a query of posts against each pose's plane over its polygons, checked: x, y,
    yaw (N,), quads (N, 2k) (or (1, 2k) with ``shared_quads``: the same for every pose), planes
    (N, 3), the window's posts, its origin and spacing."""
    x, y, w, q = _f64(px), _f64(py), _f64(yaw), _f64(quads)
    n = x.shape[0]
    if q.ndim < 2 or q.shape[q.ndim - 1] != 2 or not (q.shape[0] == n or (shared_quads and q.shape[0] == 1)):
        raise ValueError("quads must be (N, ..., 2)" + (" or (1, ..., 2)" if shared_quads else ""))
    pl = _f64(planes)
    if y.shape[0] != n or w.shape[0] != n or pl.ndim != 2 or pl.shape[0] != n or pl.shape[1] != 3:
        raise ValueError("py, yaw and planes (N, 3) must match px")
    return (x, y, w, q.reshape(q.shape[0], -1), pl, _f64(post_z), _pair(post_origin, "post_origin"),
            _pair(post_size, "post_size"))


def grid_highest_above_plane_bound(px, py, yaw, quads, planes, post_z, post_origin, post_size,
                                   Py_ssize_t r_off, Py_ssize_t c_off, Py_ssize_t grid_rows, Py_ssize_t grid_cols):
    """An upper bound (N,) of how far the ground rises above each pose's plane over its polygons.

    px, py, yaw : local centres (N,) m and headings (N,) rad
    quads : (N, ..., 2) polygon corners in the heading frame, m (their bounding box is searched)
    planes : (N, 3) a, b, c: the plane's height a + b u + c v at heading-frame offset (u, v)

    The ground is linear over every triangle of the grid and the plane is linear, so their
    difference peaks at a triangle's posts: the largest (post - plane) over the posts of the
    cells the polygons' bounding box touches bounds it from above. -inf where the box holds
    no valid post; NaN for a non-finite pose; +inf where the window misses some of the posts.
    """
    args = _plane_query(px, py, yaw, quads, planes, post_z, post_origin, post_size, False)
    cdef const double[::1] x = args[0]
    cdef const double[::1] y = args[1]
    cdef const double[::1] w = args[2]
    cdef const double[:, ::1] q = args[3]
    cdef const double[:, ::1] pl = args[4]
    cdef const double[:, ::1] pz = args[5]
    cdef const double[::1] po = args[6]
    cdef const double[::1] ps = args[7]
    cdef Py_ssize_t n = x.shape[0]
    out_arr = np.full(n, -np.inf)
    cdef double[::1] out = out_arr
    cdef Py_ssize_t k = q.shape[1] // 2
    cdef const double* pzp = _ptr2(pz)
    cdef Py_ssize_t rows = pz.shape[0]
    cdef Py_ssize_t cols = pz.shape[1]
    cdef double ox = po[0]
    cdef double oy = po[1]
    cdef double dx = ps[0]
    cdef double dy = ps[1]
    cdef Py_ssize_t i
    if n == 0 or k == 0:
        return out_arr
    if pzp == NULL:
        out_arr[:] = np.inf
        return out_arr
    for i in prange(n, nogil=True, schedule="static"):
        out[i] = _highest_above_plane_one(x[i], y[i], w[i], &q[i, 0], k, pl[i, 0], pl[i, 1], pl[i, 2], pzp, rows,
                                          cols, ox, oy, dx, dy, r_off, c_off, grid_rows, grid_cols)
    return out_arr


cdef void _plane_slab_one(double px, double py, double yaw, const double* quad, Py_ssize_t k,
                          double pa, double pb, double pc, const double* post_z, Py_ssize_t rows,
                          Py_ssize_t cols, double ox, double oy, double dx, double dy,
                          Py_ssize_t r_off, Py_ssize_t c_off, Py_ssize_t grid_rows,
                          Py_ssize_t grid_cols, double limit, double* lo, double* hi) noexcept nogil:
    """The least and largest (post - plane) over every post of every cell the bounding box of the
    corners ``quad`` (k, 2) (heading frame) touches; NaN both unless the box lies on the grid, the
    window holds all its posts and every one of them is valid (all its cells carry both triangles),
    and NaN too as soon as they are more than ``limit`` apart (a slab no caller can use)."""
    cdef double co = cos(yaw)
    cdef double si = sin(yaw)
    cdef double z, du, dv, rel, low, high
    cdef Py_ssize_t r0, r1, c0, c1, r, c
    cdef Py_ssize_t span[4]
    lo[0] = NAN
    hi[0] = NAN
    if not (isfinite(pa) and isfinite(pb) and isfinite(pc)) or not _box_cells(px, py, yaw, quad, k, ox, oy, dx, dy,
                                                                               span):
        return
    c0, c1, r0, r1 = span[0], span[1], span[2], span[3]
    if c0 < 0 or r0 < 0 or c1 > grid_cols - 1 or r1 > grid_rows - 1:
        return  # the box reaches past the grid's posts
    if c0 < c_off or r0 < r_off or c1 - c_off > cols - 1 or r1 - r_off > rows - 1:
        return
    low = INFINITY
    high = -INFINITY
    for r in range(r0, r1 + 1):
        dv = oy + <double>r * dy - py
        for c in range(c0, c1 + 1):
            z = post_z[(r - r_off) * cols + (c - c_off)]
            if not isfinite(z):
                return
            du = ox + <double>c * dx - px
            rel = z - (pa + pb * (co * du + si * dv) + pc * (co * dv - si * du))
            high = rel if rel > high else high
            low = rel if rel < low else low
        if high - low > limit:
            return
    lo[0] = low
    hi[0] = high


def grid_plane_slab(px, py, yaw, quads, planes, post_z, post_origin, post_size,
                    Py_ssize_t r_off, Py_ssize_t c_off, Py_ssize_t grid_rows, Py_ssize_t grid_cols,
                    double limit=INFINITY):
    """The slab of the ground about each pose's plane over its polygons: (lo, hi) (N,) each, m.

    px, py, yaw : local centres (N,) m and headings (N,) rad
    quads : (N, ..., 2) polygon corners in the heading frame, m (their bounding box is searched)
    planes : (N, 3) a, b, c: the plane's height a + b u + c v at heading-frame offset (u, v)

    The ground is linear over every triangle of the grid and the plane is linear, so over the
    cells the polygons' bounding box touches, ground - plane lies between the least and the
    largest (post - plane) of their posts. NaN where the box is not wholly over full cells
    held by the window (a post of NODATA, the grid's edge) or the pose is not finite, and where
    the slab is wider than ``limit`` m (the search stops there: on rough ground after a few posts).
    quads may be (1, ..., 2): the same polygons for every pose.
    """
    args = _plane_query(px, py, yaw, quads, planes, post_z, post_origin, post_size, True)
    cdef const double[::1] x = args[0]
    cdef const double[::1] y = args[1]
    cdef const double[::1] w = args[2]
    cdef const double[:, ::1] q = args[3]
    cdef const double[:, ::1] pl = args[4]
    cdef const double[:, ::1] pz = args[5]
    cdef const double[::1] po = args[6]
    cdef const double[::1] ps = args[7]
    cdef Py_ssize_t n = x.shape[0]
    cdef Py_ssize_t shared = q.shape[0] == 1
    lo_arr = np.full(n, np.nan)
    hi_arr = np.full(n, np.nan)
    cdef double[::1] lo = lo_arr
    cdef double[::1] hi = hi_arr
    cdef Py_ssize_t k = q.shape[1] // 2
    cdef const double* pzp = _ptr2(pz)
    cdef Py_ssize_t rows = pz.shape[0]
    cdef Py_ssize_t cols = pz.shape[1]
    cdef double ox = po[0]
    cdef double oy = po[1]
    cdef double dx = ps[0]
    cdef double dy = ps[1]
    cdef Py_ssize_t i
    if n == 0 or k == 0 or pzp == NULL:
        return lo_arr, hi_arr
    for i in prange(n, nogil=True, schedule="static"):
        _plane_slab_one(x[i], y[i], w[i], &q[0 if shared else i, 0], k, pl[i, 0], pl[i, 1], pl[i, 2], pzp, rows,
                        cols, ox, oy, dx, dy, r_off, c_off, grid_rows, grid_cols, limit, &lo[i], &hi[i])
    return lo_arr, hi_arr
