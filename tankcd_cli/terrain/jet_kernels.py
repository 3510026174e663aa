"""Compiled kernels of the ``jet`` mean curvature (``curvature.jet_curvature``).

Each has a numpy twin in ``curvature.py`` (the oracle); ``tests/terrain/test_jet.py`` makes
them agree. Compiled ahead of time (Cython, ``_jet.pyx``); the loops over vertices run in
parallel (OpenMP) and release the GIL.

neighbours(P, query, k, extra) -> (q, k) indices into P: ``curvature.nearest_neighbours``'
rule (the ``extra`` nearest, distances to 1e-9 of the farthest, ties by index, less the point
itself) from a kd-tree of P
jet_fit(V, normal, centre, nbr, degree) -> H (c,): ``curvature._jet_chunk``
jet_curvature(V, normal, P, pool, query, k, extra, degree) -> H (q,): both in one pass,
vertex by vertex, storing no neighbour lists
"""

from __future__ import annotations

from tankcd_cli.terrain._jet import (  # noqa: F401
    jet_curvature,
    jet_fit,
    neighbours,
)
