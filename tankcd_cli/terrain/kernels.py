"""Compiled kernels for the per-face and per-vertex passes that numpy cannot do in one sweep.

Each kernel has a numpy twin in ``curvature.py`` (the oracle); the tests make
them agree. The kernels are compiled ahead of time (Cython, ``_kernels.pyx``):
importing them costs nothing. ``cotan_accumulate`` is one serial pass over the
faces (its sums keep the faces' order, so the bits are those of the former
numba kernel); ``boundary_flags`` (and so ``open_vertex_flags``) runs over the
vertices in parallel.

cotan_accumulate(V, F) -> K (n, 3), normal sum (n, 3), mixed area (n,)
vertex_face_csr(F, n) -> start (n + 1,), face (3 m,)
boundary_flags(F, n, start, face) -> boundary (n,), nonmanifold (n,)
grow_rings(F, start, face, seed, rings) -> mask (n,)
open_vertex_flags(F, n, rings) -> boundary, nonmanifold, near
"""

from __future__ import annotations

from tankcd_cli.terrain._kernels import (  # noqa: F401
    boundary_flags,
    cotan_accumulate,
    grow_rings,
    open_vertex_flags,
    vertex_face_csr,
)
