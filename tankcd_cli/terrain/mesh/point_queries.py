"""Point location, heights and slopes on a mesh-layout surface, and the highest ground under
body points, compiled ahead of time (Cython, ``_point_queries.pyx``) for
:class:`~tankcd_cli.terrain.mesh.surface.MeshSurface`.

A point is located in the surface's locator cells (a DEM's own cells or an irregular mesh's
triangle buckets) and tested against the triangles listed there; a DEM's full cells are read
from their posts by the arithmetic ``terrain/_post_cell.pxd`` shares with the grid layout.
"""

from tankcd_cli.terrain.mesh._point_queries import (  # noqa: F401
    BARY_EPS,
    cell_of,
    height_one,
    heights_slopes,
    highest_above,
    inside_triangle,
    locate_faces,
    locate_one,
)
from tankcd_cli.terrain.grid.post_queries import full_cell  # noqa: F401  (a DEM cell's arithmetic, shared)
