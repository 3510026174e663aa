"""The ``sphere`` mean curvature, the paper's own estimator (equations 3 to 8).

The normal curvature along each edge i-j is 1/R of the sphere through X_i, X_j and the two
ring neighbours X_{j-1}, X_{j+1} (the vertices opposite the edge), signed by the side of the
centre, weighted as in equation 2. Nearly coplanar points give zero normal curvature, never
inf or NaN. Exact on spheres and cylinders; biased where the surface twists relative to the
mesh edges (the two opposite vertices move apart in height): on z = 0.01 x^2 + 0.03 x y it
reads 4 times the true H.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.terrain.mesh.topology import EdgeTopology
from tankcd_cli.tolerances import Tolerances


def sphere_curvature(vertices: np.ndarray, faces: np.ndarray, cot: np.ndarray, normal: np.ndarray,
                     area: np.ndarray, topo: EdgeTopology, tol: Tolerances) -> np.ndarray:
    """H (n,) 1/m by the paper's four-point sphere estimator, one sphere per interior edge (boundary
    and non-manifold edges take equation 3 with the vertex normal); 0 where the mixed area is 0.

    cot : (m, 3) corner cotangents (``cotan.face_corners``); normal : (n, 3) unit upward vertex
    normals; area : (n,) mixed areas; topo : the mesh's ``EdgeTopology``."""
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
