"""The interface every terrain surface offers, whichever layout it reads: a ``typing.Protocol``
that :class:`~tankcd_cli.terrain.mesh.surface.MeshSurface` and
:class:`~tankcd_cli.terrain.grid.surface.GridSurface` both satisfy, and that matching,
collision and replay are written against.

World x, y in metres (any offset: each surface works in its own local coordinates); yaw in
radians, counter-clockwise from +x. Arrays broadcast; results are (N,) per point or pose.
Patches: quads (N, 2, 4, 2), each pose's two contact patches as convex quadrilaterals in its
heading frame (u forward, v left, from the footprint centre); planes (N, 3): z = a + b u + c v
in that frame.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Surface(Protocol):
    """Heights, normals, region classes and the exact footprint queries of a terrain."""

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of the south-west and north-east corners of the terrain's extent."""
        ...

    def to_local(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """World x, y in the surface's local coordinates (what its kernels take)."""
        ...

    def height_slope(self, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Height (N,) m and gradient dz/dx, dz/dy (N,) at world points; NaN off the terrain."""
        ...

    def height_normal(self, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Height (N,) m, unit upward normal (N, 3) and on-terrain mask (N,) at world points."""
        ...

    def heights_at(self, x, y, yaw, points) -> np.ndarray:
        """Ground heights (N, k) m at points (k, 2) of each pose's heading frame; NaN off the terrain."""
        ...

    def region_under(self, x, y, yaw, length: float, width: float) -> np.ndarray:
        """The worst region class (N,) uint8 under each footprint rectangle (length along the
        heading, width across, centred on x, y); 255 where none is known."""
        ...

    def highest_above_plane_bound(self, x, y, yaw, quads: np.ndarray, planes: np.ndarray) -> np.ndarray:
        """An upper bound (N,) m of how far the ground rises above each pose's plane over its
        polygons (+inf where none is known, -inf where no ground is under them)."""
        ...

    def plane_slab(self, x, y, yaw, quads: np.ndarray, planes: np.ndarray,
                   limit: float = float("inf")) -> tuple[np.ndarray, np.ndarray]:
        """Bounds (lo, hi) (N,) m of the ground less each pose's plane over its polygons' bounding
        box (quads (N or 1, ..., 2); NaN where none is proven: off the terrain, a slab wider than
        ``limit``, or a surface that keeps no bounds)."""
        ...

    def footprint(self, mode: int, x, y, yaw, quads: np.ndarray, planes_in: np.ndarray, eps: float,
                  arithmetic: bool = True, warm: bool = False):
        """The exact footprint pass (``terrain.footprint.footprint_batch``) over this surface's ground."""
        ...

    def support_plane_under(self, x, y, yaw, quads, exact_cells: bool = True, start=None):
        """The lowest plane over each footprint centre that no ground under the patches rises
        above: planes (N, 3), the share of the patches over terrain (N,), status (N,) (0 found)."""
        ...

    def highest_over_patches(self, x, y, yaw, quads, planes, exact_cells: bool = True):
        """How far the ground under the patches rises above each plane (N,) m, the covered share
        (N,), status (N,) (0: some ground under them)."""
        ...

    def support_and_highest(self, x, y, yaw, quads, planes):
        """Both queries from one pass: support planes (N, 3), height above the given planes (N,),
        covered share (N,), the support plane's status (N,)."""
        ...
