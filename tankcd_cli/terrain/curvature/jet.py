"""The ``jet`` mean curvature: a least-squares quartic height function (an osculating jet of
degree 4; Cazals and Pouget 2003) over the 20 nearest vertices, in the tangent frame of their
least-squares plane; H from its derivatives at the vertex. At least second order on irregular
meshes too; several times the cost of ``cotan``. Its one-sided form over the 40 nearest
vertices is every method's treatment of the boundary (``mean.py``).

``jet_curvature`` runs the compiled search and fit (``jet_fit.py``) or, with ``fast=False``,
their numpy twins here (``nearest_neighbours`` with cKDTree, ``jet_fit_numpy``): the oracle.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.terrain.curvature import jet_fit


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
    if (fast is None or fast) and len(sel) and np.isfinite(points).all():
        return pool[jet_fit.neighbours(points, local, k, extra)]
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
        vertex, in parallel, storing neither); False: ``nearest_neighbours`` and ``jet_fit_numpy``
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
    if fast is None or fast:
        vertices = np.asarray(vertices, dtype=np.float64)
        pool, points, sel, local, k, extra = _neighbour_pool(vertices, which, k, candidates)
        if np.isfinite(points).all():
            H[sel] = jet_fit.jet_curvature(vertices, normal, points, pool, local, k, extra, degree)
            return H
    nbr = nearest_neighbours(vertices, which, k, candidates, fast=False)
    for start in range(0, len(sel), chunk):
        rows = slice(start, start + chunk)
        H[sel[rows]] = jet_fit_numpy(vertices, normal, sel[rows], nbr[rows], degree)
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


def jet_fit_numpy(vertices: np.ndarray, normal: np.ndarray, centre: np.ndarray, nbr: np.ndarray,
                  degree: int) -> np.ndarray:
    """H (c,) 1/m at the vertices ``centre`` (c,) from a jet of ``degree`` (3 or 4) fitted to their
    neighbours ``nbr`` (c, k) (vertex indices), in numpy: the oracle of ``jet_fit.jet_fit``.
    normal : (n, 3) unit upward vertex normals, which orient the fitted plane."""
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
