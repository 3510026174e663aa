"""Signed mean curvature H at every vertex of a terrain mesh, 1/m: ``mean_curvature`` takes the
estimator named, gives the boundary its one-sided fits, and runs the compiled passes or their
numpy twins.

Sign convention (docs/formats.md#conventions-frames-units-signs; libigl's, VTK's and GIS tools'): with the upward
normal, a hilltop or ridge is positive, a bowl or valley negative, a plane zero.
On a height field z = f(x, y):

    H = -((1 + fy^2) fxx - 2 fx fy fxy + (1 + fx^2) fyy) / (2 (1 + fx^2 + fy^2)^(3/2))

Methods (``METHODS``), cheapest first:

``cotan``  (``cotan.py``) the discrete cotangent formula with the mixed Voronoi area
           (the paper's equation 2; Meyer, Desbrun, Schroeder and Barr 2003),
           projected on the upward vertex normal. Second order on regular grids;
           it does not converge on irregular meshes (a known property of the
           operator, shared by libigl and VTK).
``sphere`` (``sphere.py``) the paper's own estimator (equations 3 to 8): the normal curvature
           along each edge i-j is 1/R of the sphere through X_i, X_j and the two
           ring neighbours X_{j-1}, X_{j+1} (the vertices opposite the edge),
           signed by the side of the centre, weighted as in equation 2.
           Nearly coplanar points give zero normal curvature, never inf or NaN.
           Exact on spheres and cylinders; biased where the surface twists
           relative to the mesh edges (the two opposite vertices move apart
           in height): on z = 0.01 x^2 + 0.03 x y it reads 4 times the true H.
``jet``    (``jet.py``) a least-squares quartic height function (an osculating jet of
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

from tankcd_cli.terrain.curvature.cotan import cotan_curvature, face_corners, mixed_area
from tankcd_cli.terrain.curvature.jet import BOUNDARY_NEIGHBOURS, BOUNDARY_RINGS, JET_DEGREE, jet_curvature
from tankcd_cli.terrain.curvature.one_ring import cotan_accumulate, open_vertex_flags
from tankcd_cli.terrain.curvature.sphere import sphere_curvature
from tankcd_cli.terrain.mesh.topology import edge_topology
from tankcd_cli.tolerances import DEFAULT, Tolerances

METHODS = ("cotan", "sphere", "jet")


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
    return unit_or_up(acc)


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
        return OpenVertices(*open_vertex_flags(faces, n, BOUNDARY_RINGS))
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
        K, normal_sum, area = cotan_accumulate(vertices, faces)
        normal = unit_or_up(normal_sum)
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
            H = cotan_curvature(faces, edge, cot, normal, area, n)
    else:
        if fast:
            edge, cot, fnormal = face_corners(vertices, faces)
        else:
            area = mixed_area(faces, edge, cot, np.linalg.norm(fnormal, axis=1), n)
        H = sphere_curvature(vertices, faces, cot, normal, area, edge_topology(faces, n), tol)
    if open_mask.any():
        # the one-sided fits look for neighbours only near the boundary, not in a tree over all
        H[open_mask] = jet_curvature(vertices, normal, open_mask, k=BOUNDARY_NEIGHBOURS,
                                     degree=JET_DEGREE, candidates=open_verts.near, fast=fast)[open_mask]
    return H


def unit_or_up(vectors: np.ndarray) -> np.ndarray:
    """Unit vectors (n, 3) along ``vectors``; +z where one is zero or not finite."""
    norm = np.linalg.norm(vectors, axis=1)
    bad = ~(norm > 0)
    out = vectors / np.where(bad, 1.0, norm)[:, None]
    out[bad] = (0.0, 0.0, 1.0)
    return out
