"""The ``cotan`` mean curvature: the discrete cotangent formula with the mixed Voronoi area
(the paper's equation 2; Meyer, Desbrun, Schroeder and Barr 2003), projected on the upward
vertex normal, and the per-face corner arrays the ``sphere`` estimator shares.

Second order on regular grids; it does not converge on irregular meshes (a known property of
the operator, shared by libigl and VTK). ``one_ring.cotan_accumulate`` is the compiled pass
over the faces that gives the same sums.
"""

from __future__ import annotations

import numpy as np


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


def cotan_curvature(faces: np.ndarray, edge: np.ndarray, cot: np.ndarray, normal: np.ndarray, area: np.ndarray,
                    n: int) -> np.ndarray:
    """H (n,) 1/m = -(K . n) / (4 A) at each vertex, K = sum over its edges of (cot a + cot b)(X_j - X_i);
    0 where the mixed area A is 0. ``edge``, ``cot`` from ``face_corners``, ``normal`` (n, 3) unit
    upward vertex normals, ``area`` (n,) from ``mixed_area``."""
    # corner k's cotangent weighs edge k (from X[k+1] to X[k+2]):
    # it adds cot_k * edge_k to vertex k+1 and -cot_k * edge_k to vertex k+2
    idx = np.concatenate([faces[:, [1, 2, 0]].ravel(), faces[:, [2, 0, 1]].ravel()])
    w = (cot[:, :, None] * edge).reshape(-1, 3)
    w = np.concatenate([w, -w])
    K = np.column_stack([np.bincount(idx, weights=w[:, c], minlength=n) for c in range(3)])
    with np.errstate(divide="ignore", invalid="ignore"):
        H = -np.einsum("ij,ij->i", K, normal) / (4.0 * area)
    return np.where(area > 0, H, 0.0)
