"""Edge topology: each face corner's opposite edge, faces per edge, boundary vertices."""

import numpy as np

from tankcd_cli.terrain.mesh.topology import edge_topology


def test_edge_topology_boundary_and_nonmanifold():
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 2, 4]])  # edge 0-2 shared by three faces
    topo = edge_topology(F, 5)
    assert (topo.face_count > 2).sum() == 1
    assert topo.boundary_vertex.all()
    # corner k of each face is opposite edge (f[k+1], f[k+2])
    for f, fe in zip(F, topo.face_edge):
        for k in range(3):
            assert set(topo.edges[fe[k]]) == {f[(k + 1) % 3], f[(k + 2) % 3]}


def test_a_closed_surface_has_no_boundary():
    """A tetrahedron: six edges of two faces each."""
    F = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]])
    topo = edge_topology(F, 4)
    assert len(topo.edges) == 6 and (topo.face_count == 2).all() and not topo.boundary_vertex.any()
    assert (topo.edges[:, 0] < topo.edges[:, 1]).all()
