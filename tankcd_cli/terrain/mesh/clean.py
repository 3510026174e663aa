"""Mesh clean-up (merged duplicates, degenerate and repeated faces dropped), the per-face arrays
the curvature and region code share, and the test of whether a mesh looks like a terrain."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tankcd_cli.terrain.curvature.jet_fit import neighbours
from tankcd_cli.tolerances import DEFAULT, Tolerances


@dataclass(frozen=True)
class CleanMesh:
    """A cleaned triangle mesh.

    vertices : (n, 3) float64, m
    faces : (m, 3) int64
    old_to_new : (n_in,) int64 -- new index of each input vertex, -1 if dropped
    counts : what was merged or dropped, by kind
    """

    vertices: np.ndarray
    faces: np.ndarray
    old_to_new: np.ndarray
    counts: dict = field(default_factory=dict)


def clean_mesh(vertices: np.ndarray, faces: np.ndarray, tol: Tolerances = DEFAULT,
               merge: bool = True) -> CleanMesh:
    """Merge duplicate vertices, drop degenerate and repeated faces and unreferenced vertices.

    vertices : (n, 3) float, m
    faces : (m, 3) int
    merge : look for vertices closer than ``tol.merge_distance`` (skip for DEM
        posts, which are distinct by construction)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    n = len(vertices)
    counts = {"merged_vertices": 0, "degenerate_faces": 0, "repeated_faces": 0, "unreferenced_vertices": 0}

    rep = np.arange(n)
    if merge and n > 1:
        rep = _merge_representatives(vertices, tol.merge_distance)
        counts["merged_vertices"] = int(np.count_nonzero(rep != np.arange(n)))
    f = rep[faces]

    u, v, w = _face_edges(vertices, f, third=True)  # b - a, c - a, c - b by coordinate
    longest2 = np.maximum(np.maximum(_sq3(u), _sq3(v)), _sq3(w))
    area2 = np.sqrt(_sq3(_cross3(u, v)))  # twice the area
    repeated_index = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    degenerate = repeated_index | ~(area2 > 2 * tol.degenerate_area_ratio * longest2)
    counts["degenerate_faces"] = int(degenerate.sum())
    f = f[~degenerate]

    keep = _first_of_each_face(f, n)
    counts["repeated_faces"] = int(len(f) - keep.sum())
    f = f[keep]

    used = np.zeros(n, dtype=bool)
    used[f.ravel()] = True
    new_index = np.full(n, -1, dtype=np.int64)
    new_index[used] = np.arange(int(used.sum()))
    old_to_new = new_index[rep]
    counts["unreferenced_vertices"] = int(n - counts["merged_vertices"] - used.sum())
    return CleanMesh(vertices[used], new_index[f], old_to_new, counts)


def face_normal_components(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(b - a) x (c - a) of each face (a, b, c): twice its area times its unit normal, as three
    (m,) arrays x, y, z. The bits of ``np.cross`` on the gathered corners, at a fifth of the time
    (coordinate by coordinate: no (m, 3, 3) gather)."""
    return _cross3(*_face_edges(vertices, faces))


def twice_face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """|(b - a) x (c - a)| of each face (m,), m^2: the bits of ``np.linalg.norm(np.cross(...), axis=1)``."""
    return np.sqrt(_sq3(face_normal_components(vertices, faces)))


def _face_edges(vertices: np.ndarray, faces: np.ndarray, third: bool = False):
    """b - a and c - a of each face (and c - b with ``third``), each as three (m,) coordinate arrays."""
    corners = []
    for k in range(3):  # coordinate by coordinate: no (m, 3, 3) gather
        x = np.ascontiguousarray(vertices[:, k])
        corners.append((x[faces[:, 0]], x[faces[:, 1]], x[faces[:, 2]]))
    u = tuple(b - a for a, b, _ in corners)
    v = tuple(c - a for a, _, c in corners)
    return (u, v, tuple(c - b for _, b, c in corners)) if third else (u, v)


def _cross3(u, v):
    return u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]


def _sq3(u) -> np.ndarray:
    return u[0] * u[0] + u[1] * u[1] + u[2] * u[2]


SMALL_MESH_VERTICES = 250_000
"""Up to this many vertices, the compiled k-d tree first asks whether any vertex has a near
duplicate at all, and scipy (a quarter of a second to import, most of a toy mesh's classify) is
loaded only when one has; above it scipy's pair search is the faster of the two."""


def _merge_representatives(vertices: np.ndarray, distance: float) -> np.ndarray:
    """Index of the representative (lowest index) of each vertex's cluster of near-duplicates."""
    n = len(vertices)
    # centre first: the k-d tree then works on small numbers even at UTM offsets
    pts = vertices - vertices.mean(axis=0)
    if n <= SMALL_MESH_VERTICES and np.isfinite(pts).all():
        nearest = neighbours(pts, np.arange(n), 1, 2)[:, 0]  # each vertex's nearest other (cKDTree's distances)
        if not (np.linalg.norm(pts[nearest] - pts, axis=1) <= distance).any():
            return np.arange(n)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(pts).query_pairs(distance, output_type="ndarray")
    if len(pairs) == 0:
        return np.arange(n)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1, n, dtype=np.int64)
    np.minimum.at(first, label, np.arange(n))
    return first[label]


def _first_of_each_face(faces: np.ndarray, n: int) -> np.ndarray:
    """Mask keeping the first occurrence of each face (same three vertices, any order)."""
    s = np.sort(faces, axis=1)
    if n < 2_000_000:
        key = (s[:, 0] * n + s[:, 1]) * n + s[:, 2]
        _, first = np.unique(key, return_index=True)
    else:
        _, first = np.unique(s, axis=0, return_index=True)
    keep = np.zeros(len(faces), dtype=bool)
    keep[first] = True
    return keep


def height_field_problems(vertices: np.ndarray, faces: np.ndarray) -> list[str]:
    """Why a mesh is probably not a terrain seen from above (z up), in words; [] if it looks like one.

    Orientation-free tests (a terrain's winding is often inconsistent): taller than it is wide;
    faces overlapping in plan (their projected areas add up to more than the bounding box,
    as a closed object's do: every point of its outline is covered twice); most of the area
    steeper than 70 degrees (a wall, or a terrain lying on its side).
    """
    if len(faces) == 0 or len(vertices) == 0:
        return []
    nx, ny, nz = face_normal_components(vertices, faces)
    area = 0.5 * np.sqrt(nx * nx + ny * ny + nz * nz)
    total = float(area.sum())
    if not total > 0:
        return []
    plan = 0.5 * float(np.abs(nz).sum())
    ext = vertices.max(axis=0) - vertices.min(axis=0)
    problems = []
    if ext[2] > min(ext[0], ext[1]):
        problems.append(f"it is taller ({ext[2]:.4g} m) than it is wide ({min(ext[0], ext[1]):.4g} m)")
    if plan > 1.05 * ext[0] * ext[1]:
        problems.append(f"its faces overlap in plan ({plan / max(ext[0] * ext[1], 1e-300):.2f} times its "
                        "bounding box: a closed object?)")
    if plan < math.cos(math.radians(70.0)) * total:
        problems.append("most of its area is steeper than 70 degrees")
    return problems
