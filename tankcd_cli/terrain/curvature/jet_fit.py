"""The ``jet`` mean curvature's neighbour search and quartic fits, compiled ahead of time
(Cython, ``_jet_fit.pyx``); the loops over vertices run in parallel (OpenMP) without the GIL.

Each has a numpy twin in ``jet.py`` (the oracle); ``tests/terrain/curvature/test_jet_fit.py``
makes them agree.

neighbours(P, query, k, extra) -> (q, k) indices into P: ``jet.nearest_neighbours``' rule (the
    ``extra`` nearest, distances to 1e-9 of the farthest, ties by index, less the point itself)
    from a kd-tree of P
jet_fit(V, normal, centre, nbr, degree) -> H (c,): ``jet.jet_fit_numpy``
jet_curvature(V, normal, P, pool, query, k, extra, degree) -> H (q,): both in one pass,
    vertex by vertex, storing no neighbour lists
"""

from __future__ import annotations

from tankcd_cli.terrain.curvature._jet_fit import (  # noqa: F401
    jet_curvature,
    jet_fit,
    neighbours,
)
