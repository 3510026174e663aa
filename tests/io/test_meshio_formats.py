"""Formats read through meshio: the cells a surface cannot use (lines, vertices, volumes) are
counted, and a file of nothing but volumes is refused."""

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.terrain_readers import read_terrain


def test_vtk_line_cells_beside_triangles_are_counted(tmp_path):
    import meshio

    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], dtype=float)
    cells = [("triangle", np.array([[0, 1, 2], [0, 2, 3]])),
             ("line", np.array([[0, 4], [1, 4], [2, 4]])),
             ("vertex", np.array([[4]]))]
    path = tmp_path / "mixed.vtk"
    meshio.write(str(path), meshio.Mesh(points, cells))
    raw = read_terrain(str(path))
    assert raw.skipped == {"line cells": 3, "vertex cells (points)": 1}
    np.testing.assert_array_equal(raw.faces, [[0, 1, 2], [0, 2, 3]])
    assert raw.face_part is None


def test_vtu_volume_cells_are_counted_and_a_volume_alone_is_refused(tmp_path):
    import meshio

    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    path = tmp_path / "solid.vtu"
    meshio.write(str(path), meshio.Mesh(points, [("triangle", np.array([[0, 1, 2]])), ("tetra", np.array([[0, 1, 2, 3]]))]))
    raw = read_terrain(str(path))
    assert raw.skipped == {"tetra cells (volume, not a surface)": 1} and len(raw.faces) == 1
    only = tmp_path / "only.vtu"
    meshio.write(str(only), meshio.Mesh(points, [("tetra", np.array([[0, 1, 2, 3]]))]))
    with pytest.raises(InputError, match="no triangle faces.*1 tetra cells"):
        read_terrain(str(only))
