"""Every import points down: the package's layers, lowest first, as the README's layout section
names them. A module may import its own layer and those below it, never one above."""

import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "tankcd_cli"

LAYERS = [
    ("foundation", ["tankcd_cli", "tankcd_cli.errors", "tankcd_cli.names", "tankcd_cli.tolerances", "tankcd_cli._threads"]),
    ("geometry", ["tankcd_cli.geometry", "tankcd_cli.vehicle", "tankcd_cli.vehicle_mesh"]),
    ("io", ["tankcd_cli.io"]),
    ("world", ["tankcd_cli.scene"]),
    ("terrain", ["tankcd_cli.terrain"]),
    ("matching and trees", ["tankcd_cli.matching", "tankcd_cli.bvh"]),
    ("collision", ["tankcd_cli.collision"]),
    ("runs", ["tankcd_cli.replay", "tankcd_cli.tradeoff", "tankcd_cli.plots", "tankcd_cli.sample",
              "tankcd_cli.describe"]),
    ("command line", ["tankcd_cli.cli", "tankcd_cli.__main__"]),
]


def layer_of(module: str):
    best = None
    for rank, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and (best is None or len(p) > best[1]):
                best = (rank, len(p))
    return None if best is None else best[0]


def _modules():
    """Python modules and the compiled kernels' Cython sources (.pyx, .pxd), by module name."""
    for path in sorted(p for ext in ("*.py", "*.pyx", "*.pxd") for p in PACKAGE.rglob(ext)):
        name = ".".join(("tankcd_cli",) + path.relative_to(PACKAGE).with_suffix("").parts)
        yield name.removesuffix(".__init__"), path


def _imports(path: Path):
    """Every tankcd_cli import of a module, function-level ones included (they hide layering bugs too);
    in Cython sources the ``from X import`` and ``from X cimport`` lines."""
    if path.suffix in (".pyx", ".pxd"):
        for number, line in enumerate(path.read_text().splitlines(), start=1):
            match = re.match(r"\s*(?:from\s+(\S+)\s+c?import|c?import\s+(\S+))", line)
            if match:
                yield match.group(1) or match.group(2), number
        return
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno


def test_every_module_has_a_layer():
    missing = [name for name, _ in _modules() if layer_of(name) is None]
    assert not missing, f"modules in no layer (add them to LAYERS and the README): {missing}"


def test_every_import_points_down():
    upward = []
    for name, path in _modules():
        own = layer_of(name)
        for target, line in _imports(path):
            if target.startswith("tankcd_cli") and layer_of(target) is not None and layer_of(target) > own:
                upward.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {name} ({LAYERS[own][0]}) imports "
                              f"{target} ({LAYERS[layer_of(target)][0]})")
    assert not upward, "imports that run upward:\n" + "\n".join(upward)


def test_the_checker_sees_an_upward_import(tmp_path):
    # the test itself can fail: an io module importing the terrain layer is caught
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from tankcd_cli.terrain.mesh.store import read_mesh_store\n")
    targets = [t for t, _ in _imports(src)]
    assert targets == ["tankcd_cli.terrain.mesh.store"]
    assert layer_of("tankcd_cli.terrain.mesh.store") > layer_of("tankcd_cli.io.poses_csv")
