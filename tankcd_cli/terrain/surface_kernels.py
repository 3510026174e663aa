"""Point location for :mod:`tankcd_cli.terrain.surface`, compiled ahead of time (Cython).

The kernels live in ``_surface_kernels.pyx``; full DEM cells are read from their posts with
``_grid_kernels``' ``full_cell`` arithmetic.
"""

from tankcd_cli.terrain._surface_kernels import (  # noqa: F401
    BARY_EPS,
    cell_of,
    height_one,
    heights_slopes,
    highest_above,
    inside_triangle,
    locate_faces,
    locate_one,
)
from tankcd_cli.terrain.grid_kernels import full_cell  # noqa: F401
