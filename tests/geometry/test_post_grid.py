"""The grid record and the triangulation of posts: the store's convention (row 0 north, post (r, c)
at origin_x + c dx, origin_y - r dy), the south-west post given back exactly, and the triangles."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.geometry.post_grid import PostGrid, grid_faces


def test_posts_lie_where_the_convention_says():
    g = PostGrid(3, 4, 500_000.0, 4_200_010.0, 2.0, 5.0, "", "local grid (no CRS)")
    assert g.origin == (500_000.0, 4_200_010.0) and g.spacing == (2.0, 5.0)
    assert g.south_west == (500_000.0, 4_200_000.0)
    assert g.bounds() == (500_000.0, 4_200_000.0, 500_006.0, 4_200_010.0)
    x, y = g.post_xy(np.array([0, 2, 1]), np.array([0, 3, 2]))
    np.testing.assert_array_equal(x, [500_000.0, 500_006.0, 500_004.0])
    np.testing.assert_array_equal(y, [4_200_010.0, 4_200_000.0, 4_200_005.0])


@settings(max_examples=300, deadline=None)
@given(st.integers(2, 100_000), st.integers(-10**7, 10**7), st.sampled_from([0.25, 0.5, 1.0, 2.0, 30.0]),
       st.floats(1e-3, 1e3))
def test_from_south_west_gives_the_south_west_post_back(rows, y_quarters, dy_exact, dy_any):
    """The round trip through the north-west origin gives the south-west post back: exactly for
    posts on a lattice of powers of two (whole, half, quarter metres), to rounding for any."""
    y0 = y_quarters / 4
    g = PostGrid.from_south_west(rows, 3, 1.5, y0, 0.5, dy_exact)
    assert g.south_west == (1.5, y0) and g.origin_y == y0 + (rows - 1) * dy_exact
    g = PostGrid.from_south_west(rows, 3, 1.5, y0, 0.5, dy_any)
    assert abs(g.south_west[1] - y0) <= np.spacing(abs(y0) + rows * dy_any)


def test_grid_faces_counter_clockwise_and_three_post_cells():
    """Row 0 north: a full cell gives (SW, SE, NE) and (SW, NE, NW); a cell with one post missing
    the triangle of the other three; fewer, nothing."""
    vertex = np.array([[3, 4, -1], [0, 1, 2]])  # north row: NW 3, NE 4; south row: SW 0, SE 1, 2
    faces = grid_faces(vertex)
    np.testing.assert_array_equal(faces, [[0, 1, 4], [0, 4, 3], [1, 2, 4]])
    xy = np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1]], dtype=float)
    a, b, c = xy[faces[:, 0]], xy[faces[:, 1]], xy[faces[:, 2]]
    u, v = b - a, c - a
    assert (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0] > 0).all()
    assert len(grid_faces(np.array([[-1, -1], [0, 1]]))) == 0


@pytest.mark.parametrize("seed", range(3))
def test_grid_faces_cover_every_cell_with_three_posts(seed):
    rng = np.random.default_rng(seed)
    valid = rng.random((9, 11)) > 0.2
    vertex = np.full(valid.shape, -1)
    vertex[valid] = np.arange(valid.sum())
    faces = grid_faces(vertex)
    corners = np.stack([valid[:-1, :-1], valid[:-1, 1:], valid[1:, :-1], valid[1:, 1:]]).sum(axis=0)
    assert len(faces) == 2 * (corners == 4).sum() + (corners == 3).sum()
    assert len(np.unique(np.sort(faces, axis=1), axis=0)) == len(faces)
