"""ESRI ASCII grids read as a mesh: posts at cell centres, rows from the south, NODATA left out,
UTM digits kept, and every malformed file named in one line."""

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import grid_faces
from tankcd_cli.io.terrain_readers import read_terrain
from tests.conftest import write_asc


def test_asc_posts_rows_and_corner_convention(tmp_path):
    z = [[7, 8, 9], [4, 5, 6], [1, 2, 3]]  # north row first
    path = write_asc(tmp_path / "g.asc", z, cellsize=2.0, xll=100.0, yll=200.0, corner=True)
    raw = read_terrain(str(path))
    grid = raw.grid
    np.testing.assert_allclose(grid.geometry.south_west, [101.0, 201.0])  # corner + half a cell
    assert grid.geometry.origin == (101.0, 205.0) and grid.geometry.spacing == (2.0, 2.0)  # the north-west post
    # row 0 of the grid is the north row (heights 7 8 9), the last the south row: heights 1 2 3
    np.testing.assert_allclose(raw.vertices[grid.vertex[0]], [[101, 205, 7], [103, 205, 8], [105, 205, 9]])
    south = raw.vertices[grid.vertex[-1]]
    np.testing.assert_allclose(south, [[101, 201, 1], [103, 201, 2], [105, 201, 3]])
    assert len(raw.faces) == 8
    # triangles are counter-clockwise seen from above
    p = raw.vertices[raw.faces]
    cross_z = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]
    assert (cross_z > 0).all()


def test_asc_nodata_posts_are_left_out(tmp_path):
    z = np.arange(16, dtype=float).reshape(4, 4)
    z[0, 0] = -9999
    z[2, 2] = -9999
    raw = read_terrain(str(write_asc(tmp_path / "g.asc", z, nodata=-9999)))
    assert len(raw.vertices) == 14
    assert (raw.grid.vertex == -1).sum() == 2
    assert not np.isin(-9999.0, raw.vertices[:, 2])
    # every quad with three valid posts keeps one triangle: 9 quads, 4 touch a hole (one twice)
    assert len(raw.faces) == len(grid_faces(raw.grid.vertex))


def test_asc_utm_coordinates_keep_their_digits(tmp_path):
    z = np.ones((3, 3))
    raw = read_terrain(str(write_asc(tmp_path / "g.asc", z, cellsize=0.5, xll=500000.25, yll=4500000.75)))
    assert raw.vertices[:, 0].min() == 500000.25
    assert raw.vertices[:, 1].max() == 4500000.75 + 1.0


@pytest.mark.parametrize("text,fragment", [
    ("", "empty"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2 3\n", "expected 2 x 2 = 4 values"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n3 x\n", "line 7 value 2"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 nan\n3 4\n", "non-finite height"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize -1\n1 2\n3 4\n", "cellsize must be positive"),
    ("ncols two\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n3 4\n", "ncols must be a whole number"),
    ("nrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n3 4\n", "lacks ncols"),
    ("ncols 2\nnrows 1\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n", "no cells to triangulate"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\nNODATA_value 0\n0 0\n0 0\n", "every post is NODATA"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\nNODATA_value 0\n0 1\n1 0\n", "no cell has three valid posts"),
])
def test_asc_malformed(tmp_path, text, fragment):
    path = tmp_path / "bad.asc"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        read_terrain(str(path))
    assert fragment in str(err.value)
    assert str(path) in str(err.value)
    assert "\n" not in str(err.value)


def test_asc_bom_and_crlf(tmp_path):
    path = tmp_path / "g.asc"
    path.write_bytes("\ufeffncols 2\r\nnrows 2\r\nxllcenter 0\r\nyllcenter 0\r\ncellsize 1\r\n1 2\r\n3 4\r\n".encode("utf-8"))
    raw = read_terrain(str(path))
    assert len(raw.vertices) == 4
