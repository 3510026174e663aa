"""Compiled twins of the per-post passes of ``tiled_classify`` (compiled ahead of time (Cython),
``_post_passes.pyx``; they run without the GIL).

Each kernel performs the same floating-point operations in the same order as
its numpy twin in ``tiled_classify.py`` (no fused multiply-add, no
reassociation), so the two give the same bits; the tests hold them to it.
(The disk sums stay numpy: offset by offset over whole arrays they run at
memory speed already.)

fd_mean_curvature(z, dx, dy) -> H (rows, cols), as ``tiled_classify.grid_mean_curvature_fd``
post_areas(z, dx, dy) -> area (rows, cols), as ``tiled_classify.post_areas``
"""

from __future__ import annotations

from tankcd_cli.terrain.grid._post_passes import fd_mean_curvature, post_areas  # noqa: F401
