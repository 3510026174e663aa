"""Point location on irregular terrain meshes: a uniform grid of triangle buckets.

Each bucket lists the triangles whose x, y bounding box overlaps it, so a
query inspects the few triangles of one bucket: O(1) per point for meshes
whose triangles are of similar size. Regular DEM grids need no buckets at all
(the post raster gives the cell directly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TriangleBuckets:
    """origin : (2,) x, y of the lower-left corner of bucket (0, 0), m
    cell : bucket size, m
    shape : (ny, nx)
    start : (ny * nx + 1,) int64 -- bucket b holds face[start[b]:start[b + 1]]
    face : (k,) int32 or int64 -- triangle ids, bucket by bucket
    """

    origin: np.ndarray
    cell: float
    shape: tuple[int, int]
    start: np.ndarray
    face: np.ndarray


def build_buckets(vertices: np.ndarray, faces: np.ndarray, cell: float | None = None) -> TriangleBuckets:
    """Bucket every triangle by its x, y bounding box (vectorized over all triangles)."""
    lo = np.empty((len(faces), 2))
    hi = np.empty((len(faces), 2))
    for k in range(2):  # coordinate by coordinate: no (m, 3, 2) gather, no reduction over a short axis
        x = np.ascontiguousarray(vertices[:, k])
        a, b, c = x[faces[:, 0]], x[faces[:, 1]], x[faces[:, 2]]
        lo[:, k] = np.minimum(np.minimum(a, b), c)
        hi[:, k] = np.maximum(np.maximum(a, b), c)
    world_lo, world_hi = lo.min(axis=0), hi.max(axis=0)
    span = np.maximum(world_hi - world_lo, 1e-9)
    if cell is None:
        # about one triangle pair per bucket, but never more buckets than 4 per triangle
        typical = float(np.median(np.maximum(hi - lo, 0).max(axis=1)))
        cell = max(typical, float(np.sqrt(span[0] * span[1] / (4.0 * len(faces)))), 1e-6)
    nx, ny = int(span[0] // cell) + 1, int(span[1] // cell) + 1
    c0 = np.clip(((lo - world_lo) // cell).astype(np.int64), 0, [nx - 1, ny - 1])
    c1 = np.clip(((hi - world_lo) // cell).astype(np.int64), 0, [nx - 1, ny - 1])
    wx, wy = c1[:, 0] - c0[:, 0] + 1, c1[:, 1] - c0[:, 1] + 1
    count = wx * wy
    owner = np.repeat(np.arange(len(faces)), count)
    offset = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    col = c0[owner, 0] + offset % wx[owner]
    row = c0[owner, 1] + offset // wx[owner]
    bucket = row * nx + col
    order = np.argsort(bucket, kind="stable")
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    np.cumsum(np.bincount(bucket, minlength=nx * ny), out=start[1:])
    face_dtype = np.int32 if len(faces) < 2**31 else np.int64
    return TriangleBuckets(world_lo, float(cell), (ny, nx), start, owner[order].astype(face_dtype))
