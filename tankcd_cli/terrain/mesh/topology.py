"""Undirected edges of a triangle mesh and how many faces share each (boundary and non-manifold
edges), in one vectorized pass."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class EdgeTopology:
    """Undirected edges of a mesh and the faces around them.

    edges : (e, 2) int64 -- vertex pairs, lower index first
    face_edge : (m, 3) int64 -- edge index of the edge opposite each face corner
    face_count : (e,) int64 -- faces sharing each edge (1 = boundary, >2 = non-manifold)
    boundary_vertex : (n,) bool -- vertex on a boundary or non-manifold edge
    """

    edges: np.ndarray
    face_edge: np.ndarray
    face_count: np.ndarray
    boundary_vertex: np.ndarray


def edge_topology(faces: np.ndarray, n_vertices: int) -> EdgeTopology:
    """Edges opposite each corner: corner k of face f is opposite edge (f[k+1], f[k+2])."""
    m = len(faces)
    half = np.stack([faces[:, [1, 2]], faces[:, [2, 0]], faces[:, [0, 1]]], axis=1).reshape(-1, 2)
    lo, hi = half.min(axis=1), half.max(axis=1)
    key = lo * np.int64(n_vertices) + hi
    uniq, inverse, count = np.unique(key, return_inverse=True, return_counts=True)
    edges = np.column_stack([uniq // n_vertices, uniq % n_vertices])
    boundary_vertex = np.zeros(n_vertices, dtype=bool)
    boundary_vertex[edges[count != 2].ravel()] = True
    return EdgeTopology(edges, inverse.reshape(m, 3), count, boundary_vertex)
