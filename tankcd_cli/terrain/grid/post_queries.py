"""Height and class queries on a DEM held only as posts, compiled ahead of time (Cython).

The surface is the grid layout's implicit one (docs/formats.md): each cell split
along its SW-NE diagonal into (SW, SE, NE) and (SW, NE, NW); a cell with three
valid posts carries the one triangle of those three; fewer, nothing.

Every kernel takes a *window* of the grid: ``post_z`` (rows, cols), south row
first, NaN at NODATA, whose post [0, 0] is post [r_off, c_off] of the whole
grid (row index from the south), and ``post_origin``, the local x, y of the
whole grid's post [0, 0]. Cell indices and in-cell fractions are computed in
the whole grid's indices, so a result never depends on the window it was read
through (a replay split into parts gives the same bytes as one run).

The kernels live in ``_post_queries.pyx``; ``full_cell``'s arithmetic (``full_cell_c``) is
``terrain/_post_cell.pxd``, which the mesh layout's kernels share.
"""

from tankcd_cli.terrain.grid._post_queries import (  # noqa: F401
    BARY_EPS,
    full_cell,
    grid_height_one,
    grid_highest_above_plane_bound,
    grid_plane_slab,
    grid_heights_at_offsets,
    grid_heights_slopes,
    grid_worst_class,
)
