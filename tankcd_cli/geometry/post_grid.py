"""A raster of posts and the implicit triangulation between them, which both the mesh reading of
a DEM and the grid layout's surface take (each cell split along its SW-NE diagonal)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Grid:
    """A regular raster of posts (vertices at cell centres).

    origin : (2,) float, m -- world x, y of post (row 0, column 0), the south-west one
    spacing : (2,) float, m -- post spacing along x (columns) and y (rows)
    vertex : (nrows, ncols) int64 -- vertex index of each post, -1 for NODATA;
        row index grows northwards.
    """

    origin: np.ndarray
    spacing: np.ndarray
    vertex: np.ndarray


def grid_faces(vertex: np.ndarray) -> np.ndarray:
    """Triangles (k, 3) over a post raster (-1 = missing), counter-clockwise seen from above.

    Full quads split along the SW-NE diagonal; quads with exactly three posts
    give the triangle of those three.
    """
    a = vertex[:-1, :-1]  # SW
    b = vertex[:-1, 1:]   # SE
    c = vertex[1:, 1:]    # NE
    d = vertex[1:, :-1]   # NW
    ok = np.stack([a >= 0, b >= 0, c >= 0, d >= 0])
    count = ok.sum(axis=0)
    full = count == 4
    tris = [np.column_stack([a[full], b[full], c[full]]), np.column_stack([a[full], c[full], d[full]])]
    three = count == 3
    # the triangle of the three valid corners, kept counter-clockwise
    for missing, corners in ((0, (b, c, d)), (1, (a, c, d)), (2, (a, b, d)), (3, (a, b, c))):
        sel = three & ~ok[missing]
        tris.append(np.column_stack([k[sel] for k in corners]))
    return np.concatenate(tris).astype(np.int64)
