"""The surface interface: both layouts' surfaces satisfy ``Surface`` with the same parameters, and
the protocol holds every query the rest of the package asks of a surface."""

import ast
import inspect
from pathlib import Path

import numpy as np

from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.terrain.grid.surface import GridSurface
from tankcd_cli.terrain.surface import Surface

PACKAGE = Path(__file__).resolve().parents[2] / "tankcd_cli"


def _protocol_methods():
    return sorted(n for n, v in vars(Surface).items() if callable(v) and not n.startswith("_"))


def test_both_layouts_are_surfaces_with_the_protocols_parameters():
    z = np.add.outer(np.arange(6.0), np.arange(7.0)) * 0.1
    mesh = S.surface_of(S.dem_terrain(z))
    grid = GridSurface.from_arrays(z[::-1].copy(), np.zeros(z.shape, np.uint8), PostGrid(*z.shape, 0.0, 5.0))
    for surface in (mesh, grid):
        assert isinstance(surface, Surface)
        for name in _protocol_methods():
            want = list(inspect.signature(getattr(Surface, name)).parameters)
            got = list(inspect.signature(getattr(type(surface), name)).parameters)
            assert got == want, (type(surface).__name__, name)


def test_the_protocol_holds_every_query_the_callers_make():
    """Every method called on a ``surface`` (or ``setup.surface``) outside terrain/ is in ``Surface``."""
    called = set()
    for path in PACKAGE.rglob("*.py"):
        if "terrain" in path.relative_to(PACKAGE).parts[:1]:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                owner = node.func.value
                if (isinstance(owner, ast.Name) and owner.id == "surface") or \
                        (isinstance(owner, ast.Attribute) and owner.attr == "surface"):
                    called.add(node.func.attr)
    assert called and called <= set(_protocol_methods()), called - set(_protocol_methods())
