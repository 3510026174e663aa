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

from tankcd_cli.terrain._footprint import MAX_POLY, footprint_batch  # noqa: F401
