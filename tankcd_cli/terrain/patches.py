"""The public queries of the ground under a vehicle's contact patches (both surfaces share them)."""

from __future__ import annotations

import numpy as np

from tankcd_cli.tolerances import EPS_XY


class PatchQueries:
    """The public queries of the ground under a vehicle's patches, shared by both surfaces
    (``MeshSurface``, ``GridSurface``), each of which provides ``footprint`` (the pass).

    Patches are (N, 2, 4, 2) quadrilaterals in each pose's heading frame; planes (N, 3) are
    a + b u + c v in that frame; x, y are world footprint centres, yaw rad.
    """

    def heights_at(self, x, y, yaw, points) -> np.ndarray:
        """Ground heights (N, k) m at points (k, 2) given in each pose's heading frame (u forward,
        v left, from the footprint centre); NaN off the terrain."""
        yaw = np.asarray(yaw, dtype=float)
        c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        px = np.asarray(x, dtype=float)[:, None] + c * points[:, 0] - s * points[:, 1]
        py = np.asarray(y, dtype=float)[:, None] + s * points[:, 0] + c * points[:, 1]
        return self.height_slope(px, py)[0]

    def support_plane_under(self, x, y, yaw, quads, exact_cells: bool = True, start=None):
        """The lowest plane over each footprint centre that no ground under the patches rises
        above: planes (N, 3), the share of the patches over terrain (N,), status (N,) (0 found).

        ``start``: planes (N, 3) near the answer (their slopes start the search: fewer steps,
        the same planes to rounding; see ``geometry._support_plane.support_plane_from_c``)."""
        quads = np.ascontiguousarray(quads)
        if start is None:
            return self.footprint(0, x, y, yaw, quads, np.zeros((len(quads), 3)), EPS_XY, arithmetic=exact_cells)
        start = np.where(np.isfinite(start), start, 0.0)
        return self.footprint(0, x, y, yaw, quads, np.ascontiguousarray(start), EPS_XY, arithmetic=exact_cells,
                              warm=True)

    def highest_over_patches(self, x, y, yaw, quads, planes, exact_cells: bool = True):
        """How far the ground under the patches rises above each plane (signed, m; (N,)), the
        share of the patches over terrain (N,), status (N,) (0: some ground under them).

        ``exact_cells=False`` clips every cell's triangles instead of reading full DEM cells by
        arithmetic: the oracle the arithmetic is tested against."""
        out, covered, status = self.footprint(1, x, y, yaw, np.ascontiguousarray(quads), np.ascontiguousarray(planes),
                                              EPS_XY, arithmetic=exact_cells)
        return out[:, 0], covered, status

    def support_and_highest(self, x, y, yaw, quads, planes):
        """Both queries from one pass over the same ground: the lowest supporting plane (N, 3),
        how far the ground rises above each given plane (N,; NaN where no ground is under the
        patches), the covered share (N,) and the support plane's status (N,). The search for the
        support plane starts from the given planes' slopes (see ``support_plane_under``)."""
        planes = np.ascontiguousarray(planes)
        out, covered, status = self.footprint(2, x, y, yaw, np.ascontiguousarray(quads), planes, EPS_XY,
                                              warm=bool(np.isfinite(planes).all()))
        return out[:, :3], out[:, 3], covered, status
