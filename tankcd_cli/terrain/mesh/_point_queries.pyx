"""Compiled kernels of ``tankcd_cli.terrain.mesh.point_queries`` (see its docstring).

A point's face: the triangles listed in its locator cell (then the 8 neighbouring cells, for a
point on a cell's border) that hold it to ``BARY_EPS`` in barycentric coordinates, the highest
of them on overhangs, vertical faces skipped. Its height and slope: a DEM's full cell from the
four posts (``_post_cell.full_cell_c``), else the face's plane; NaN over no face.
"""

from cython.parallel cimport prange
from libc.math cimport isfinite, isnan, INFINITY, NAN
from libc.stdint cimport int64_t

import numpy as np

from tankcd_cli.geometry.arrays import f64 as _f64, i64 as _i64, pair as _pair

from tankcd_cli.terrain._post_cell cimport full_cell_c, ifloor

BARY_EPS = 1e-9  # points this close (in barycentric units) to a triangle's edge count as inside
cdef double _BARY_EPS = 1e-9


cdef struct Mesh:
    # the triangles and their locator cells (all C-contiguous)
    const double* V  # (n, vcols) local x, y, z
    Py_ssize_t vcols
    const int64_t* F  # (m, fcols)
    Py_ssize_t fcols
    const double* plane  # (m, pcols): z = p0 + p1 x + p2 y
    Py_ssize_t pcols
    double ox, oy  # cell origin
    double sx, sy  # cell size
    Py_ssize_t ny, nx
    const int64_t* start  # (ny nx + 1,)
    const int64_t* cell_face


cdef struct Posts:
    # a DEM's post raster (rows, cols), south row first, NaN at NODATA; rows = cols = 0 for meshes
    const double* z
    Py_ssize_t rows, cols
    double ox, oy, dx, dy


# --- helpers ---------------------------------------------------------------------------------

cdef inline void _cell_of(double x, double y, const Mesh* m, Py_ssize_t* row, Py_ssize_t* col) noexcept nogil:
    cdef Py_ssize_t c = ifloor((x - m.ox) / m.sx)
    cdef Py_ssize_t r = ifloor((y - m.oy) / m.sy)
    # a point on the far edge of the last cell belongs to it
    if c == m.nx and x - m.ox <= <double>m.nx * m.sx * (1 + 1e-12):
        c = m.nx - 1
    if r == m.ny and y - m.oy <= <double>m.ny * m.sy * (1 + 1e-12):
        r = m.ny - 1
    row[0] = r
    col[0] = c


cdef inline bint _inside_triangle(double x, double y, const Mesh* m, Py_ssize_t f) noexcept nogil:
    cdef const int64_t* tri = m.F + f * m.fcols
    cdef const double* pa = m.V + tri[0] * m.vcols
    cdef const double* pb = m.V + tri[1] * m.vcols
    cdef const double* pc = m.V + tri[2] * m.vcols
    cdef double ax = pa[0]
    cdef double ay = pa[1]
    cdef double e1x = pb[0] - ax
    cdef double e1y = pb[1] - ay
    cdef double e2x = pc[0] - ax
    cdef double e2y = pc[1] - ay
    cdef double det = e1x * e2y - e1y * e2x
    if det == 0.0:
        return False
    cdef double px = x - ax
    cdef double py = y - ay
    cdef double l1 = (px * e2y - py * e2x) / det
    cdef double l2 = (e1x * py - e1y * px) / det
    return l1 >= -_BARY_EPS and l2 >= -_BARY_EPS and l1 + l2 <= 1.0 + _BARY_EPS


cdef Py_ssize_t _best_in_cell(double x, double y, Py_ssize_t row, Py_ssize_t col, const Mesh* m) noexcept nogil:
    if row < 0 or col < 0 or row >= m.ny or col >= m.nx:
        return -1
    cdef Py_ssize_t cell = row * m.nx + col
    cdef Py_ssize_t best = -1
    cdef double best_z = -INFINITY
    cdef double z
    cdef const double* p
    cdef Py_ssize_t s, f
    for s in range(m.start[cell], m.start[cell + 1]):
        f = m.cell_face[s]
        p = m.plane + f * m.pcols
        if isnan(p[1]):
            continue  # vertical face: no height of its own
        if _inside_triangle(x, y, m, f):
            z = p[0] + p[1] * x + p[2] * y
            if z > best_z:
                best_z = z
                best = f
    return best


cdef Py_ssize_t _locate_one(double x, double y, const Mesh* m) noexcept nogil:
    cdef Py_ssize_t row, col, dr, dc
    _cell_of(x, y, m, &row, &col)
    cdef Py_ssize_t best = _best_in_cell(x, y, row, col, m)
    if best < 0:
        # a point on a cell's border may lie only in a neighbour's triangle
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                if best < 0 and (dr != 0 or dc != 0):
                    best = _best_in_cell(x, y, row + dr, col + dc, m)
    return best


cdef void _height_one(double x, double y, const Posts* g, const Mesh* m,
                      double* z, double* gx, double* gy) noexcept nogil:
    if not (isfinite(x) and isfinite(y)):
        z[0] = NAN
        gx[0] = NAN
        gy[0] = NAN
        return
    cdef Py_ssize_t rows = g.rows
    cdef Py_ssize_t cols = g.cols
    cdef double u, v
    cdef Py_ssize_t c, r
    if rows >= 2 and cols >= 2:
        u = (x - g.ox) / g.dx
        v = (y - g.oy) / g.dy
        c = ifloor(u)
        r = ifloor(v)
        if c == cols - 1 and u <= <double>(cols - 1) + 1e-9:
            c = cols - 2
        if r == rows - 1 and v <= <double>(rows - 1) + 1e-9:
            r = rows - 2
        if 0 <= c < cols - 1 and 0 <= r < rows - 1:
            full_cell_c(g.z, cols, r, c, u - <double>c, v - <double>r, g.dx, g.dy, z, gx, gy)
            if isfinite(z[0]):
                return
    cdef Py_ssize_t best = _locate_one(x, y, m)
    if best < 0:
        z[0] = NAN
        gx[0] = NAN
        gy[0] = NAN
        return
    cdef const double* p = m.plane + best * m.pcols
    z[0] = p[0] + p[1] * x + p[2] * y
    gx[0] = p[1]
    gy[0] = p[2]


cdef double _highest_one(const double* R, const double* p, const double* points, Py_ssize_t npts,
                         Py_ssize_t stride, const Posts* g, const Mesh* m) noexcept nogil:
    """max over the body points (npts, stride >= 3) moved by x -> R x + p on terrain of ground - z; -inf if none."""
    cdef double worst = -INFINITY
    cdef double wx, wy, wz, gz, gx, gy
    cdef const double* q
    cdef Py_ssize_t k
    for k in range(npts):
        q = points + stride * k
        wx = R[0] * q[0] + R[1] * q[1] + R[2] * q[2] + p[0]
        wy = R[3] * q[0] + R[4] * q[1] + R[5] * q[2] + p[1]
        wz = R[6] * q[0] + R[7] * q[1] + R[8] * q[2] + p[2]
        _height_one(wx, wy, g, m, &gz, &gx, &gy)
        if isfinite(gz) and gz - wz > worst:
            worst = gz - wz
    return worst


# --- argument conversion ------------------------------------------------------------------------


cdef class _Args:
    """Holds the converted arrays (keeping them alive) behind the Mesh and Posts structs."""
    cdef object keep
    cdef Mesh mesh
    cdef Posts posts

    def __init__(self, post_z, post_origin, post_size, V, F, plane, origin, size, Py_ssize_t ny, Py_ssize_t nx,
                 start, cell_face, bint with_posts):
        cdef const double[:, ::1] pz
        cdef const double[::1] po, ps, o, s
        cdef const double[:, ::1] v = _f64(V)
        cdef const int64_t[:, ::1] f = _i64(F)
        cdef const double[:, ::1] pl = _f64(plane)
        cdef const int64_t[::1] st = _i64(start)
        cdef const int64_t[::1] cf = _i64(cell_face)
        o = _pair(origin, "origin")
        s = _pair(size, "size")
        self.keep = [v, f, pl, st, cf]
        if v.shape[0] > 0 and v.shape[1] < 2:
            raise ValueError("V must have x, y columns")
        if f.shape[0] > 0 and f.shape[1] < 3:
            raise ValueError("F must have 3 columns")
        if pl.shape[0] > 0 and pl.shape[1] < 3:
            raise ValueError("plane must have 3 columns")
        self.mesh.V = &v[0, 0] if v.shape[0] > 0 and v.shape[1] > 0 else NULL
        self.mesh.vcols = v.shape[1]
        self.mesh.F = &f[0, 0] if f.shape[0] > 0 and f.shape[1] > 0 else NULL
        self.mesh.fcols = f.shape[1]
        self.mesh.plane = &pl[0, 0] if pl.shape[0] > 0 and pl.shape[1] > 0 else NULL
        self.mesh.pcols = pl.shape[1]
        self.mesh.ox = o[0]
        self.mesh.oy = o[1]
        self.mesh.sx = s[0]
        self.mesh.sy = s[1]
        self.mesh.ny = ny
        self.mesh.nx = nx
        if ny > 0 and nx > 0 and st.shape[0] < ny * nx + 1:
            raise ValueError("start must hold ny * nx + 1 offsets")
        self.mesh.start = &st[0] if st.shape[0] > 0 else NULL
        self.mesh.cell_face = &cf[0] if cf.shape[0] > 0 else NULL
        self.posts.z = NULL
        self.posts.rows = 0
        self.posts.cols = 0
        self.posts.ox = self.posts.oy = 0.0
        self.posts.dx = self.posts.dy = 1.0
        if with_posts:
            pz = _f64(post_z)
            po = _pair(post_origin, "post_origin")
            ps = _pair(post_size, "post_size")
            self.keep.append(pz)
            self.posts.rows = pz.shape[0]
            self.posts.cols = pz.shape[1]
            self.posts.z = &pz[0, 0] if pz.shape[0] > 0 and pz.shape[1] > 0 else NULL
            self.posts.ox = po[0]
            self.posts.oy = po[1]
            self.posts.dx = ps[0]
            self.posts.dy = ps[1]


# --- Python-level kernels ----------------------------------------------------------------------

def cell_of(double x, double y, origin, size, Py_ssize_t ny, Py_ssize_t nx):
    """(row, col) of the locator cell holding local point (x, y) (may be outside the grid)."""
    cdef Mesh m
    cdef const double[::1] o = _pair(origin, "origin")
    cdef const double[::1] s = _pair(size, "size")
    cdef Py_ssize_t row, col
    m.ox = o[0]
    m.oy = o[1]
    m.sx = s[0]
    m.sy = s[1]
    m.ny = ny
    m.nx = nx
    _cell_of(x, y, &m, &row, &col)
    return row, col


def inside_triangle(double x, double y, V, F, Py_ssize_t f):
    """Whether (x, y) lies in face f (with BARY_EPS); False for a degenerate face."""
    cdef _Args a = _Args(None, None, None, V, F, np.empty((0, 3)), np.zeros(2), np.ones(2), 0, 0,
                         np.zeros(1, np.int64), np.zeros(0, np.int64), False)
    if not 0 <= f < len(a.keep[1]):
        raise IndexError("face index out of range")
    return bool(_inside_triangle(x, y, &a.mesh, f))


def locate_one(double x, double y, V, F, plane, origin, size, Py_ssize_t ny, Py_ssize_t nx, start, cell_face):
    """The face under one local point, -1 if none (the highest on overhangs)."""
    cdef _Args a = _Args(None, None, None, V, F, plane, origin, size, ny, nx, start, cell_face, False)
    return _locate_one(x, y, &a.mesh)


def locate_faces(px, py, V, F, plane, origin, size, Py_ssize_t ny, Py_ssize_t nx, start, cell_face):
    """Face under each local point, -1 if none; on overhangs the highest face."""
    cdef _Args a = _Args(None, None, None, V, F, plane, origin, size, ny, nx, start, cell_face, False)
    cdef const double[::1] x = _f64(px)
    cdef const double[::1] y = _f64(py)
    cdef Py_ssize_t n = x.shape[0]
    if y.shape[0] < n:
        raise ValueError("py is shorter than px")
    out_arr = np.full(n, -1, np.int64)
    cdef int64_t[::1] out = out_arr
    cdef const Mesh* m = &a.mesh
    cdef Py_ssize_t i
    for i in prange(n, nogil=True, schedule="static"):
        if isfinite(x[i]) and isfinite(y[i]):
            out[i] = _locate_one(x[i], y[i], m)
    return out_arr


def height_one(double x, double y, post_z, post_origin, post_size, V, F, plane, origin, size, Py_ssize_t ny,
               Py_ssize_t nx, start, cell_face):
    """Height and gradient at one local point (NaN off the terrain): see ``heights_slopes``."""
    cdef _Args a = _Args(post_z, post_origin, post_size, V, F, plane, origin, size, ny, nx, start, cell_face, True)
    cdef double z, gx, gy
    _height_one(x, y, &a.posts, &a.mesh, &z, &gx, &gy)
    return z, gx, gy


def heights_slopes(px, py, post_z, post_origin, post_size, V, F, plane, origin, size, Py_ssize_t ny,
                   Py_ssize_t nx, start, cell_face):
    """Height and gradient (dz/dx, dz/dy) of the terrain at local points; NaN off the terrain.

    ``post_z`` (rows, cols), NaN for NODATA, is a DEM's post raster: a full DEM
    cell is evaluated by arithmetic on its four posts (split along the SW-NE
    diagonal, as the mesh is). Anything else (cells with a missing post,
    irregular meshes: an empty ``post_z``) goes through the located face.
    """
    cdef _Args a = _Args(post_z, post_origin, post_size, V, F, plane, origin, size, ny, nx, start, cell_face, True)
    cdef const double[::1] x = _f64(px)
    cdef const double[::1] y = _f64(py)
    cdef Py_ssize_t n = x.shape[0]
    if y.shape[0] < n:
        raise ValueError("py is shorter than px")
    z_arr = np.empty(n)
    gx_arr = np.empty(n)
    gy_arr = np.empty(n)
    cdef double[::1] z = z_arr
    cdef double[::1] gx = gx_arr
    cdef double[::1] gy = gy_arr
    cdef const Mesh* m = &a.mesh
    cdef const Posts* g = &a.posts
    cdef Py_ssize_t i
    for i in prange(n, nogil=True, schedule="static"):
        _height_one(x[i], y[i], g, m, &z[i], &gx[i], &gy[i])
    return z_arr, gx_arr, gy_arr


def highest_above(R, position, points, post_z, post_origin, post_size, V, F, plane, origin, size, Py_ssize_t ny,
                  Py_ssize_t nx, start, cell_face):
    """For each pose, how far the ground rises above the body points (k, 3) moved by x -> R x + p
    (local coordinates): max over the points on terrain of ground - z; -inf if none is on terrain."""
    cdef _Args a = _Args(post_z, post_origin, post_size, V, F, plane, origin, size, ny, nx, start, cell_face, True)
    cdef const double[:, :, ::1] rot = _f64(R)
    cdef const double[:, ::1] pos = _f64(position)
    cdef const double[:, ::1] pts = _f64(points)
    cdef Py_ssize_t n = rot.shape[0]
    cdef Py_ssize_t npts = pts.shape[0]
    if n > 0 and (rot.shape[1] != 3 or rot.shape[2] != 3):
        raise ValueError("R must be (n, 3, 3)")
    if pos.shape[0] < n or (n > 0 and pos.shape[1] < 3):
        raise ValueError("position must be (n, 3)")
    if npts > 0 and pts.shape[1] < 3:
        raise ValueError("points must be (k, 3)")
    out_arr = np.full(n, -np.inf)
    cdef double[::1] out = out_arr
    cdef const Mesh* m = &a.mesh
    cdef const Posts* g = &a.posts
    cdef const double* body = &pts[0, 0] if npts > 0 else NULL
    cdef Py_ssize_t stride = pts.shape[1]
    cdef Py_ssize_t i
    for i in prange(n, nogil=True, schedule="static"):
        out[i] = _highest_one(&rot[i, 0, 0], &pos[i, 0], body, npts, stride, g, m)
    return out_arr
