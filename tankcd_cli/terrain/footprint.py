"""The ground under the two track contact patches, exactly (compiled ahead of time (Cython), batched over poses).

For a piecewise-linear terrain the highest ground point relative to any plane
over a convex patch lies at a vertex of some terrain triangle clipped to the
patch. So each triangle overlapping a patch is clipped to it
(Sutherland-Hodgman), and the clipped polygons' corners are the exact
constraint set: for the rigid-hull reference (the lowest plane above all of
them, over the footprint centre) and for any matcher's penetration (the
highest of them above its plane). The clipped areas also tell how much of the
footprint lies on the terrain.

Patches are convex quadrilaterals in the heading frame (u forward, v left,
horizontal, origin at the footprint centre): the vertical projections of the
tilted hull's contact rectangles.

The kernels live in ``_footprint.pyx``: the Sutherland-Hodgman clipping and the
per-patch point collectors are C functions there; ``footprint_batch`` is the
Python face.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from tankcd_cli.terrain._footprint import MAX_POLY, footprint_batch  # noqa: F401


class MeshGround(NamedTuple):
    """A mesh's faces and the locator the pass finds them by (``mesh.surface.MeshSurface``)."""

    vertices: np.ndarray  # (n, 3) local
    faces: np.ndarray  # (m, 3)
    plane: np.ndarray  # (m, 3) each face's plane
    cell_origin: np.ndarray  # (2,) the locator grid
    cell_size: np.ndarray  # (2,)
    ny: int
    nx: int
    cell_start: np.ndarray  # CSR of the faces per locator cell
    cell_face: np.ndarray
    listed_once: bool  # whether each face sits in one cell only (no duplicates to skip)


class PostGround(NamedTuple):
    """A DEM's posts, or a window of them (``grid.post_queries``' window convention)."""

    post_z: np.ndarray  # (rows, cols), south row first, NaN at NODATA
    post_origin: np.ndarray  # (2,) local x, y of the whole grid's post [0, 0]
    post_size: np.ndarray  # (2,) spacing
    r_off: int = 0  # the window's post [0, 0] is the grid's [r_off, c_off]
    c_off: int = 0

