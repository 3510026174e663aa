"""The curvature estimators' passes over faces and one-rings, compiled ahead of time (Cython,
``_one_ring.pyx``; importing them costs nothing).

Each has a numpy twin (the oracle): ``cotan_accumulate`` the sums of ``cotan.py`` (one serial
pass over the faces, in their order); ``open_vertex_flags`` the edge counts of
``mesh.topology.edge_topology`` as ``mean.open_vertices`` reads them (the vertices in parallel).

cotan_accumulate(V, F) -> K (n, 3) = sum (cot a + cot b)(X_j - X_i), upward normal sum (n, 3),
    mixed Voronoi area (n,)
vertex_face_csr(F, n) -> start (n + 1,), face (3 m,): the faces around each vertex
boundary_flags(F, n, start, face) -> boundary (n,), nonmanifold (n,): on an edge of one face,
    or of three or more
grow_rings(F, start, face, seed, rings) -> mask (n,): the vertices within ``rings`` edge hops of a seed
open_vertex_flags(F, n, rings) -> boundary, nonmanifold, near (within ``rings`` hops of either)
"""

from __future__ import annotations

from tankcd_cli.terrain.curvature._one_ring import (  # noqa: F401
    boundary_flags,
    cotan_accumulate,
    grow_rings,
    open_vertex_flags,
    vertex_face_csr,
)
