"""Finite cylinders (flat caps): the exact intersection test and the paper's two-plane projection test.

Both are answered by one GJK distance routine (Gilbert, Johnson and Keerthi
1988) on the Minkowski difference of two convex sets, through their support
mappings. A cylinder with centre c, unit axis a, half-length h and radius r
has the support point, in direction d,

    c + sign(d . a) h a + r (d - (d . a) a) / |d - (d . a) a|.

``cylinders_intersect`` runs GJK in 3D. GJK keeps, at every step, an upper
bound |v| on the distance (the closest point of the current simplex) and a
lower bound v . w / |v| (the separating plane through the newest support
point w); it stops when they are within ``tol`` of each other, so the answer
"touching or intersecting" (distance <= tol) versus "apart" is certain up to
``tol`` (1e-9 m by default). Touching counts as intersecting.

``projections_overlap`` is the paper's method: the two cylinders are
projected onto a plane (the vehicle's xoy or yoz) and their exact shadows
(the convex hull of the two projected caps: rectangles with elliptic ends,
rectangles, discs) are tested for overlap, by the same GJK on support
mappings projected into the plane. The paper reports a collision unless the
shadows are disjoint in one of the planes: conservative (a real collision
overlaps in every projection), never missing one.

The GJK routine and its batch (``gjk_distance``, ``cylinders_distance_batch``, parallel over
the A cylinders) are compiled ahead of time (Cython, ``_cylinders.pyx``); the small Gram systems
of the simplex faces are solved there by an LU factorisation written out in the kernel (the
operations of OpenBLAS's getf2/getrs on x86-64 with FMA), so the distances are the same bits on
every machine.
"""

from __future__ import annotations

import numpy as np

# GJK itself is compiled ahead of time (Cython): ``_cylinders.pyx``
from tankcd_cli.geometry._cylinders import (  # noqa: F401
    MAX_ITER,
    TOL,
    cylinders_distance_batch,
    gjk_distance,
)


def cylinders_intersect(cA, aA, hA, rA, cB, aB, hB, rB, tol: float = TOL) -> np.ndarray:
    """Exact test (N,) bool: cylinders A_i (centres (N, 3), unit axes (N, 3)) against cylinder B."""
    cA, aA = np.ascontiguousarray(cA, float).reshape(-1, 3), np.ascontiguousarray(aA, float).reshape(-1, 3)
    d = cylinders_distance_batch(cA, aA, float(hA), float(rA), np.asarray(cB, float), np.asarray(aB, float),
                                 float(hB), float(rB), np.zeros(3), tol)
    return d <= tol


def projections_overlap(cA, aA, hA, rA, cB, aB, hB, rB, normals=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
                        tol: float = TOL) -> np.ndarray:
    """The paper's test (N,) bool: a collision unless the shadows are disjoint on one of the planes
    (default: xoy, normal z, and yoz, normal x)."""
    cA, aA = np.ascontiguousarray(cA, float).reshape(-1, 3), np.ascontiguousarray(aA, float).reshape(-1, 3)
    hit = np.ones(len(cA), dtype=bool)
    for nrm in normals:
        d = cylinders_distance_batch(cA, aA, float(hA), float(rA), np.asarray(cB, float), np.asarray(aB, float),
                                     float(hB), float(rB), np.asarray(nrm, float), tol)
        hit &= d <= tol
    return hit
