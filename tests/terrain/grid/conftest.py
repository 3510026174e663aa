"""The fixture the grid surface tests share: one DEM as both layouts' surfaces, read through many windows."""

import pytest

from tests.terrain.grid.dems import grid_and_mesh_surfaces, rough_dem


@pytest.fixture(scope="module")
def both_surfaces():
    import tankcd_cli.terrain.grid.surface as gs

    z = rough_dem(120, 140, seed=6)
    old = gs.BLOCK, gs.WINDOW_POSTS
    gs.BLOCK, gs.WINDOW_POSTS = 32, 20_000  # many windows: results must not depend on them
    try:
        yield grid_and_mesh_surfaces(z), z
    finally:
        gs.BLOCK, gs.WINDOW_POSTS = old
