"""Signed mean curvature H at every vertex of a terrain mesh, 1/m.

Sign convention (the contract's, as libigl, VTK and GIS tools): with the upward
normal, a hilltop or ridge is positive, a bowl or valley negative, a plane zero.
On a height field z = f(x, y):

    H = -((1 + fy^2) fxx - 2 fx fy fxy + (1 + fx^2) fyy) / (2 (1 + fx^2 + fy^2)^(3/2))

Methods (``METHODS``), cheapest first:

``cotan``  the discrete cotangent formula with the mixed Voronoi area
           (the paper's equation 2; Meyer, Desbrun, Schroeder and Barr 2003),
           projected on the upward vertex normal. Second order on regular grids;
           it does not converge on irregular meshes (a known property of the
           operator, shared by libigl and VTK).
``sphere`` the paper's own estimator (equations 3 to 8): the normal curvature
           along each edge i-j is 1/R of the sphere through X_i, X_j and the two
           ring neighbours X_{j-1}, X_{j+1} (the vertices opposite the edge),
           signed by the side of the centre, weighted as in equation 2.
           Nearly coplanar points give zero normal curvature, never inf or NaN.
           Exact on spheres and cylinders; biased where the surface twists
           relative to the mesh edges (the two opposite vertices move apart
           in height): on z = 0.01 x^2 + 0.03 x y it reads 4 times the true H.
``jet``    a least-squares quartic height function (an osculating jet of
           degree 4; Cazals and Pouget 2003) over the 20 nearest vertices, in
           the tangent frame of their least-squares plane; H from its
           derivatives at the vertex. At least second order on irregular
           meshes too; several times the cost of ``cotan``.

Boundary vertices (and vertices on non-manifold edges) have no closed one-ring,
so no one-ring formula applies there. Every method gives them the same explicit
treatment: the one-sided quartic fit of ``jet`` over their 40 nearest vertices
(nearest by distance, not mesh rings, which on a Delaunay boundary run along
far-reaching slivers).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from tankcd_cli.terrain.mesh import EdgeTopology, edge_topology
from tankcd_cli.tolerances import DEFAULT, Tolerances

METHODS = ("cotan", "sphere", "jet")


def face_corners(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-face edge vectors, corner cotangents and upward normals.

    Returns
    -------
    edge : (m, 3, 3) float, m -- edge[:, k] = X[f[k+2]] - X[f[k+1]], the edge opposite corner k
    cot : (m, 3) float -- cotangent of the angle at each corner
    normal : (m, 3) float, m^2 -- face normal of length twice the face area, turned so that z >= 0
    """
    p = vertices[faces]  # (m, 3 corners, 3)
    edge = p[:, [2, 0, 1]] - p[:, [1, 2, 0]]
    normal = np.cross(edge[:, 2], -edge[:, 1])  # (b - a) x (c - a)
    flip = normal[:, 2] < 0
    normal[flip] *= -1
    double_area = np.linalg.norm(normal, axis=1)
    # the angle at corner k lies between the edges to its two neighbours
    u = p[:, [1, 2, 0]] - p
    v = p[:, [2, 0, 1]] - p
    dot = np.einsum("mkc,mkc->mk", u, v)
    cot = dot / double_area[:, None]
    return edge, cot, normal


def vertex_normals(vertices: np.ndarray, faces: np.ndarray, face_normal: np.ndarray | None = None) -> np.ndarray:
    """Unit upward vertex normals (n, 3): area-weighted sum of upward face normals.

    A vertex whose faces' normals cancel (impossible for upward-turned faces
    unless all are vertical) gets +z.
    """
    if face_normal is None:
        face_normal = face_corners(vertices, faces)[2]
    n = len(vertices)
    acc = np.column_stack([np.bincount(faces.ravel(), weights=np.repeat(face_normal[:, c], 3), minlength=n)
                           for c in range(3)])
    return _unit_or_up(acc)


def mixed_area(faces: np.ndarray, edge: np.ndarray, cot: np.ndarray, double_area: np.ndarray, n: int) -> np.ndarray:
    """A_mixed of Meyer et al. (2003) at each vertex, m^2 (n,).

    Non-obtuse triangles give each corner its Voronoi area; an obtuse triangle
    gives half its area to the obtuse corner and a quarter to the others.
    """
    len2 = np.einsum("mkc,mkc->mk", edge, edge)
    # corner k is adjacent to edges k+1 (to X[k+2]... ) and k+2; Voronoi share of corner k:
    voronoi = (len2[:, [2, 0, 1]] * cot[:, [2, 0, 1]] + len2[:, [1, 2, 0]] * cot[:, [1, 2, 0]]) / 8.0
    area = double_area / 2.0
    obtuse = cot < 0
    any_obtuse = obtuse.any(axis=1)
    share = np.where(any_obtuse[:, None], np.where(obtuse, area[:, None] / 2, area[:, None] / 4), voronoi)
    return np.bincount(faces.ravel(), weights=share.ravel(), minlength=n)


FAST_MIN_VERTICES = 0  # compiled ahead of time, the kernels cost nothing to load: every mesh takes them


def use_fast_path(n: int, fast: bool | None = None) -> bool:
    """Whether to use the compiled kernels for a mesh of ``n`` vertices."""
    return n >= FAST_MIN_VERTICES if fast is None else fast


class OpenVertices(NamedTuple):
    """Vertices without a closed one-ring, (n,) bool each.

    boundary : on an edge with one face
    nonmanifold : on an edge with three or more faces
    near : within BOUNDARY_RINGS edge hops of either (where their one-sided fits
        look for neighbours); None when not computed (every vertex is a candidate)
    """

    boundary: np.ndarray
    nonmanifold: np.ndarray
    near: np.ndarray | None

    @property
    def mask(self) -> np.ndarray:
        return self.boundary | self.nonmanifold


def open_vertices(faces: np.ndarray, n: int, fast: bool | None = None) -> OpenVertices:
    """Find the vertices that no one-ring formula can serve."""
    if use_fast_path(n, fast):
        from tankcd_cli.terrain import kernels

        return OpenVertices(*kernels.open_vertex_flags(faces, n, BOUNDARY_RINGS))
    topo = edge_topology(faces, n)
    nonmanifold = np.zeros(n, dtype=bool)
    nonmanifold[topo.edges[topo.face_count > 2].ravel()] = True
    boundary = np.zeros(n, dtype=bool)
    boundary[topo.edges[topo.face_count == 1].ravel()] = True
    used = np.zeros(n, dtype=bool)
    used[faces.ravel()] = True
    return OpenVertices(boundary | ~used, nonmanifold, None)


def mean_curvature(vertices: np.ndarray, faces: np.ndarray, method: str = "cotan",
                   tol: Tolerances = DEFAULT, open_verts: OpenVertices | None = None,
                   fast: bool | None = None) -> np.ndarray:
    """Signed mean curvature H (n,) at each vertex, 1/m.

    vertices : (n, 3) float64, m (any offset: all arithmetic is on differences)
    faces : (m, 3) int, a cleaned mesh (no zero-area faces)
    method : one of ``METHODS``
    open_verts : the result of ``open_vertices``, if already known
    fast : use the compiled kernels (default: yes; False takes the numpy path, their oracle)
    """
    if method not in METHODS:
        raise ValueError(f"unknown curvature method {method!r}; choose one of {', '.join(METHODS)}")
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    n = len(vertices)
    fast = use_fast_path(n, fast)
    if open_verts is None:
        open_verts = open_vertices(faces, n, fast)
    open_mask = open_verts.mask
    if fast:
        from tankcd_cli.terrain import kernels

        K, normal_sum, area = kernels.cotan_accumulate(vertices, faces)
        normal = _unit_or_up(normal_sum)
    else:
        edge, cot, fnormal = face_corners(vertices, faces)
        normal = vertex_normals(vertices, faces, fnormal)
    if method == "jet":
        H = jet_curvature(vertices, normal, ~open_mask, fast=fast)
    elif method == "cotan":
        if fast:
            with np.errstate(divide="ignore", invalid="ignore"):
                H = np.where(area > 0, -np.einsum("ij,ij->i", K, normal) / (4.0 * area), 0.0)
        else:
            area = mixed_area(faces, edge, cot, np.linalg.norm(fnormal, axis=1), n)
            H = _cotan(faces, edge, cot, normal, area, n)
    else:
        if fast:
            edge, cot, fnormal = face_corners(vertices, faces)
        else:
            area = mixed_area(faces, edge, cot, np.linalg.norm(fnormal, axis=1), n)
        H = _sphere(vertices, faces, cot, normal, area, edge_topology(faces, n), tol)
    if open_mask.any():
        # the one-sided fits look for neighbours only near the boundary, not in a tree over all
        H[open_mask] = jet_curvature(vertices, normal, open_mask, k=BOUNDARY_NEIGHBOURS,
                                     degree=JET_DEGREE, candidates=open_verts.near, fast=fast)[open_mask]
    return H


def _unit_or_up(vectors: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(vectors, axis=1)
    bad = ~(norm > 0)
    out = vectors / np.where(bad, 1.0, norm)[:, None]
    out[bad] = (0.0, 0.0, 1.0)
    return out


def _cotan(faces, edge, cot, normal, area, n):
    """-(K . n) / (4 A): K = sum over edges of (cot a + cot b)(X_j - X_i)."""
    # corner k's cotangent weighs edge k (from X[k+1] to X[k+2]):
    # it adds cot_k * edge_k to vertex k+1 and -cot_k * edge_k to vertex k+2
    idx = np.concatenate([faces[:, [1, 2, 0]].ravel(), faces[:, [2, 0, 1]].ravel()])
    w = (cot[:, :, None] * edge).reshape(-1, 3)
    w = np.concatenate([w, -w])
    K = np.column_stack([np.bincount(idx, weights=w[:, c], minlength=n) for c in range(3)])
    with np.errstate(divide="ignore", invalid="ignore"):
        H = -np.einsum("ij,ij->i", K, normal) / (4.0 * area)
    return np.where(area > 0, H, 0.0)


def _sphere(vertices, faces, cot, normal, area, topo: EdgeTopology, tol: Tolerances):
    """The paper's four-point sphere estimator, one sphere per interior edge."""
    n = len(vertices)
    e = len(topo.edges)
    i, j = topo.edges[:, 0], topo.edges[:, 1]
    weight = np.bincount(topo.face_edge.ravel(), weights=cot.ravel(), minlength=e)  # cot a + cot b
    # the vertices opposite each edge: the corner whose opposite edge it is
    corner_vertex = faces.ravel()
    order = np.argsort(topo.face_edge.ravel(), kind="stable")
    first = np.searchsorted(topo.face_edge.ravel()[order], np.arange(e))
    interior = topo.face_count == 2
    p = np.where(interior, corner_vertex[order[np.minimum(first, len(order) - 1)]], -1)
    q = np.where(interior, corner_vertex[order[np.minimum(first + 1, len(order) - 1)]], -1)

    d_j = vertices[j] - vertices[i]
    len2 = np.einsum("ij,ij->i", d_j, d_j)
    kappa_i = np.zeros(e)
    kappa_j = np.zeros(e)
    ii = np.flatnonzero(interior)
    if len(ii):
        d = np.stack([d_j[ii], vertices[p[ii]] - vertices[i[ii]], vertices[q[ii]] - vertices[i[ii]]], axis=1)
        A = 2.0 * d  # rows: 2 (X_k - X_i)
        L = np.einsum("ekc,ekc->ek", d, d)
        # Cramer: centre (relative to X_i) c = adj(A) L / det(A); solve without dividing
        r0, r1, r2 = A[:, 0], A[:, 1], A[:, 2]
        c01, c12, c20 = np.cross(r0, r1), np.cross(r1, r2), np.cross(r2, r0)
        det = np.einsum("ij,ij->i", r0, c12)
        adjL = c12 * L[:, [0]] + c20 * L[:, [1]] + c01 * L[:, [2]]  # = det * centre
        scale = np.linalg.norm(r0, axis=1) * np.linalg.norm(r1, axis=1) * np.linalg.norm(r2, axis=1)
        norm_adjL = np.linalg.norm(adjL, axis=1)
        ok = (np.abs(det) > tol.singular_ratio * scale) & (norm_adjL > 0)
        inv_r = np.where(ok, np.abs(det) / np.where(ok, norm_adjL, 1.0), 0.0)
        # sign: + when the centre lies below the vertex along its normal
        side_i = -np.einsum("ij,ij->i", adjL, normal[i[ii]]) * np.sign(det)
        side_j = -np.einsum("ij,ij->i", adjL - det[:, None] * d[:, 0], normal[j[ii]]) * np.sign(det)
        kappa_i[ii] = np.sign(side_i) * inv_r
        kappa_j[ii] = np.sign(side_j) * inv_r
    other = ~interior  # boundary and non-manifold edges: equation 3 with the vertex normal
    if other.any():
        with np.errstate(divide="ignore", invalid="ignore"):
            kappa_i[other] = -2.0 * np.einsum("ij,ij->i", d_j[other], normal[i[other]]) / len2[other]
            kappa_j[other] = 2.0 * np.einsum("ij,ij->i", d_j[other], normal[j[other]]) / len2[other]
    contrib = weight * len2 / 8.0
    num = np.bincount(i, weights=contrib * kappa_i, minlength=n) + np.bincount(j, weights=contrib * kappa_j, minlength=n)
    with np.errstate(divide="ignore", invalid="ignore"):
        H = num / area
    return np.where(area > 0, H, 0.0)


JET_NEIGHBOURS = 20  # a symmetric 5x5 stencil less its corners on a regular grid
BOUNDARY_NEIGHBOURS = 40  # a one-sided quartic needs more rows of points
BOUNDARY_RINGS = 8  # the 40 nearest lie within 5 rings of a regular grid; 8 leaves room
JET_DEGREE = 4  # a quartic: its second derivatives err at O(h^2) on irregular meshes, O(h^4) on symmetric stencils


def _neighbour_pool(vertices: np.ndarray, which: np.ndarray, k: int, candidates: np.ndarray | None):
    """Where the neighbours are looked for: pool (m,) vertex indices, their centred points (m, 3),
    the selected vertices (q,) and their places in the pool, k and the candidates to rank."""
    if candidates is None:
        pool = np.arange(len(vertices))
        points = vertices
    else:
        pool = np.flatnonzero(candidates | which)
        points = vertices[pool]
    k = min(k, len(pool) - 1)
    extra = min(k + 1 + 16, len(pool))  # room to break ties between equidistant points by index
    centre = points.mean(axis=0)  # small numbers even at UTM offsets
    sel = np.flatnonzero(which)
    return pool, points - centre, sel, np.searchsorted(pool, sel), k, extra


def nearest_neighbours(vertices: np.ndarray, which: np.ndarray, k: int = JET_NEIGHBOURS,
                       candidates: np.ndarray | None = None, fast: bool | None = None) -> np.ndarray:
    """Indices (len(which), k) of the k nearest other vertices of each selected vertex.

    Distance, not mesh rings: on a boundary the rings of a Delaunay mesh run
    along hull slivers far from the vertex, whereas the nearest points stay close.
    The k + 1 + 16 nearest are ranked by distance to 1e-9 of the farthest of them,
    equal ranks by vertex index, and the vertex itself is dropped.
    fast : the compiled kd-tree (default; not for non-finite points), False: cKDTree (the oracle)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    pool, points, sel, local, k, extra = _neighbour_pool(vertices, which, k, candidates)
    if use_fast_path(len(vertices), fast) and len(sel) and np.isfinite(points).all():
        from tankcd_cli.terrain import jet_kernels

        return pool[jet_kernels.neighbours(points, local, k, extra)]
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    dist, local = tree.query(points[local], extra, workers=-1)
    idx = pool[local.reshape(len(sel), extra)]
    dist = dist.reshape(len(sel), extra)
    # deterministic whatever the pool: nearest first, equal distances (to 1e-9) by vertex index
    scale = np.maximum(dist[:, -1:], 1e-300)
    order = np.lexsort((idx, np.round(dist / scale * 1e9)), axis=-1)
    idx = np.take_along_axis(idx, order, axis=1)
    idx = np.where(idx == sel[:, None], -1, idx)  # the vertex itself is the fit's origin, not a sample
    keep = np.argsort(idx < 0, axis=1, kind="stable")[:, :k]
    return np.take_along_axis(idx, keep, axis=1)


_MONOMIALS = {3: 9, 4: 14}  # monomials of a jet of that degree through the origin
# # u v uu uv vv uuu uuv uvv vvv


def jet_curvature(vertices: np.ndarray, normal: np.ndarray, which: np.ndarray, chunk: int = 16384,
                  k: int = JET_NEIGHBOURS, degree: int = JET_DEGREE,
                  candidates: np.ndarray | None = None, fast: bool | None = None) -> np.ndarray:
    """Mean curvature from a least-squares polynomial fit over the k nearest neighbours.

    vertices : (n, 3) float64, m
    normal : (n, 3) unit upward vertex normals (to orient the fitted normal)
    which : (n,) bool, the vertices to compute
    candidates : (n,) bool, where to look for neighbours (default: everywhere)
    fast : the compiled kernel (default: yes; it finds the neighbours and fits them vertex by
        vertex, in parallel, storing neither); False: ``nearest_neighbours`` and ``_jet_chunk``
        in numpy, its oracle
    Returns (n,) with values at ``which`` (zeros elsewhere), 1/m.
    """
    n = len(vertices)
    H = np.zeros(n)
    sel = np.flatnonzero(which)
    if len(sel) == 0:
        return H
    if n < 4:
        return H
    if use_fast_path(n, fast):
        vertices = np.asarray(vertices, dtype=np.float64)
        pool, points, sel, local, k, extra = _neighbour_pool(vertices, which, k, candidates)
        if np.isfinite(points).all():
            from tankcd_cli.terrain import jet_kernels

            H[sel] = jet_kernels.jet_curvature(vertices, normal, points, pool, local, k, extra, degree)
            return H
    nbr = nearest_neighbours(vertices, which, k, candidates, fast=False)
    for start in range(0, len(sel), chunk):
        rows = slice(start, start + chunk)
        H[sel[rows]] = _jet_chunk(vertices, normal, sel[rows], nbr[rows], degree)
    return H


def _fit_normal(d: np.ndarray, valid: np.ndarray, hint: np.ndarray) -> np.ndarray:
    """Upward normal of the least-squares plane through the vertex and its neighbours.

    Face-weighted normals can be turned far off by a near-vertical sliver on a
    mesh boundary; the plane through the whole neighbourhood cannot.
    """
    dv = d * valid[:, :, None]
    count = valid.sum(axis=1)[:, None, None] + 1.0  # the vertex itself sits at the origin
    mean = dv.sum(axis=1, keepdims=True) / count
    cov = np.einsum("cki,ckj->cij", dv, dv) / count - np.einsum("cki,ckj->cij", mean, mean)
    _, vec = np.linalg.eigh(cov)
    nrm = vec[:, :, 0]
    # upward where the plane is not vertical; a wall takes the side of the face normals
    side = np.where(np.abs(nrm[:, 2]) > 1e-6, nrm[:, 2], np.einsum("ij,ij->i", nrm, hint))
    nrm = np.where((side < 0)[:, None], -nrm, nrm)
    return nrm


def _jet_chunk(vertices, normal, centre, nbr, degree):
    d = vertices[nbr] - vertices[centre][:, None, :]  # (c, k, 3): exact differences even at UTM offsets
    valid = np.ones(nbr.shape, dtype=bool)
    nz = _fit_normal(d, valid, normal[centre])
    # tangent frame: t1 perpendicular to n, from whichever world axis is least parallel
    helper = np.where(np.abs(nz[:, [0]]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    t1 = np.cross(nz, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(nz, t1)
    s = np.sqrt(np.einsum("ckx,ckx->ck", d, d).mean(axis=1))
    s = np.where(s > 0, s, 1.0)  # scaled coordinates keep the normal equations well conditioned
    u = np.einsum("ckx,cx->ck", d, t1) / s[:, None]
    v = np.einsum("ckx,cx->ck", d, t2) / s[:, None]
    w = np.einsum("ckx,cx->ck", d, nz) / s[:, None]
    uu, uv, vv = u * u, u * v, v * v
    columns = [u, v, uu, uv, vv, uu * u, uu * v, u * vv, vv * v]
    if degree >= 4:
        columns += [uu * uu, uu * uv, uu * vv, uv * vv, vv * vv]
    B = np.stack(columns, axis=2)  # products, not powers: np.power is several times slower
    Bt = B.transpose(0, 2, 1)
    M = Bt @ B
    rhs = (Bt @ w[:, :, None])[:, :, 0]
    count = _MONOMIALS[degree]
    ridge = 1e-10 * np.trace(M, axis1=1, axis2=2) / count + 1e-300
    M += ridge[:, None, None] * np.eye(count)
    coef = np.linalg.solve(M, rhs[:, :, None])[:, :, 0]
    fu, fv = coef[:, 0], coef[:, 1]
    fuu, fuv, fvv = 2 * coef[:, 2] / s, coef[:, 3] / s, 2 * coef[:, 4] / s
    g = 1.0 + fu * fu + fv * fv
    return -((1 + fv * fv) * fuu - 2 * fu * fv * fuv + (1 + fu * fu) * fvv) / (2.0 * g ** 1.5)
