"""A raster of posts: its geometry (``PostGrid``, the one record every layer uses for a DEM's
grid), the vertices a DEM read as a mesh gives its posts (``PostVertices``), and the implicit
triangulation between posts (``grid_faces``: each cell split along its SW-NE diagonal), which
the mesh reading of a DEM and the grid layout's surface share.

One convention throughout, the store's: row 0 is the northernmost row, column 0 the
westernmost, and post (r, c) lies at x = origin_x + c dx, y = origin_y - r dy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PostGrid:
    """The geometry of a raster of posts.

    rows, cols : posts north-south and west-east
    origin_x, origin_y : world x, y of post [0, 0], the north-west post, m
    dx, dy : post spacing along x (columns) and y (rows), m
    crs_wkt : the CRS (WKT); empty for a local grid of unknown CRS
    crs_name : the CRS in words
    """

    rows: int
    cols: int
    origin_x: float = 0.0
    origin_y: float = 0.0
    dx: float = 1.0
    dy: float = 1.0
    crs_wkt: str = ""
    crs_name: str = "local grid (no CRS)"

    @classmethod
    def from_south_west(cls, rows: int, cols: int, x0: float, y0: float, dx: float, dy: float,
                        **crs) -> "PostGrid":
        """The grid whose south-west post (row rows - 1, column 0) is at x0, y0, as ESRI grids and
        a DEM mesh's vertices count: origin_y = y0 + (rows - 1) dy. ``south_west`` gives y0 back
        to rounding (exactly whenever y0 and the span are multiples of a power of two, as posts at
        whole or half metres are)."""
        return cls(int(rows), int(cols), float(x0), float(y0) + (int(rows) - 1) * float(dy), float(dx), float(dy),
                   **crs)

    @property
    def origin(self) -> tuple[float, float]:
        """World x, y of the north-west post, m."""
        return (self.origin_x, self.origin_y)

    @property
    def spacing(self) -> tuple[float, float]:
        """dx, dy, m."""
        return (self.dx, self.dy)

    @property
    def south_west(self) -> tuple[float, float]:
        """World x, y of the south-west post (row rows - 1, column 0), m."""
        return (self.origin_x, self.origin_y - (self.rows - 1) * self.dy)

    def bounds(self) -> tuple[float, float, float, float]:
        """West, south, east, north: the outermost posts' coordinates, m."""
        west, south = self.south_west
        return west, south, self.origin_x + (self.cols - 1) * self.dx, self.origin_y

    def post_xy(self, row, col) -> tuple[np.ndarray, np.ndarray]:
        """World x, y of posts (row, col) (any shapes that broadcast), m."""
        return (self.origin_x + np.asarray(col) * self.dx, self.origin_y - np.asarray(row) * self.dy)


@dataclass(frozen=True)
class PostVertices:
    """A DEM read as a mesh: the vertex each post became.

    geometry : the grid's PostGrid
    vertex : (rows, cols) int64, row 0 north (the geometry's rows) -- vertex index of each
        post, -1 for NODATA
    """

    geometry: PostGrid
    vertex: np.ndarray


def grid_faces(vertex: np.ndarray) -> np.ndarray:
    """Triangles (k, 3) over a raster of vertex indices (rows, cols), row 0 north, -1 missing;
    counter-clockwise seen from above.

    Full quads split along the SW-NE diagonal; quads with exactly three posts give the
    triangle of those three. The order is fixed: every full quad's (SW, SE, NE), then every full
    quad's (SW, NE, NW), then the three-post quads' triangles by missing corner; within each,
    quad by quad from the south row.
    """
    vertex = vertex[::-1]  # the south row first: the order the faces come in
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
