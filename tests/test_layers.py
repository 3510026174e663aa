"""Every import points down: the package's layers, lowest first, as the README's layout section
names them. A module may import its own layer and those below it, never one above. No module
imports itself through others (no import circle, function-level imports included), and none
imports another module's private names."""

import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "tankcd_cli"

LAYERS = [
    ("foundation", ["tankcd_cli", "tankcd_cli.errors", "tankcd_cli.names", "tankcd_cli.tolerances", "tankcd_cli.threads",
                    "tankcd_cli._threads"]),
    ("geometry", ["tankcd_cli.geometry", "tankcd_cli.vehicle", "tankcd_cli.vehicle_mesh"]),
    ("io", ["tankcd_cli.io"]),
    ("world", ["tankcd_cli.scene"]),
    ("terrain", ["tankcd_cli.terrain"]),
    ("matching and trees", ["tankcd_cli.matching", "tankcd_cli.bvh"]),
    ("collision", ["tankcd_cli.collision"]),
    ("runs", ["tankcd_cli.replay", "tankcd_cli.tradeoff", "tankcd_cli.plots", "tankcd_cli.sample",
              "tankcd_cli.describe", "tankcd_cli.describe_outputs", "tankcd_cli.describe_terrain"]),
    ("review", ["tankcd_cli.report"]),
    ("library face", ["tankcd_cli.api"]),
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
    for target, _, line, _ in _import_statements(path):
        yield target, line


def _import_statements(path: Path):
    """(module, names imported from it, line, whether a Cython cimport) for every import of a
    module: ``from X import a, b`` gives (X, [a, b], ...), ``import X`` gives (X, [], ...)."""
    if path.suffix in (".pyx", ".pxd"):
        lines = path.read_text().splitlines()
        for number, line in enumerate(lines, start=1):
            match = re.match(r"\s*(?:from\s+(\S+)\s+(c?import)\s+(.*)|(c?import)\s+(\S+))", line)
            if not match:
                continue
            if match.group(1):
                names = match.group(3)
                k = number
                while names.rstrip().endswith("(") or ("(" in names and ")" not in names):  # a parenthesised list
                    names += " " + lines[k]
                    k += 1
                names = [n.split(" as ")[0].strip() for n in names.strip("() \\").replace("(", "").replace(")", "").split(",")]
                yield match.group(1), [n for n in names if n and not n.startswith("#")], number, match.group(2) == "cimport"
            else:
                yield match.group(5), [], number, match.group(4) == "cimport"
        return
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module, [a.name for a in node.names], node.lineno, False
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, [], node.lineno, False


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


# --- import circles ---------------------------------------------------------------------------

def _resolve(target: str, names: list, modules: set) -> set:
    """The package modules an import statement loads: the deepest module of its path, and each
    imported name that is a module itself (``from tankcd_cli.terrain import synthetic``)."""
    out = set()
    parts = target.split(".")
    for k in range(len(parts), 0, -1):
        if ".".join(parts[:k]) in modules:
            out.add(".".join(parts[:k]))
            break
    out.update(f"{target}.{n}" for n in names if f"{target}.{n}" in modules)
    return out


def import_graph(sources: dict) -> dict:
    """{module: the package modules it imports}, from {module: path}."""
    modules = set(sources)
    graph = {}
    for name, path in sources.items():
        edges = set()
        for target, names, _, _ in _import_statements(path):
            if target.startswith("tankcd_cli"):
                edges |= _resolve(target, names, modules)
        graph[name] = edges - {name}
    return graph


def import_circles(graph: dict) -> list:
    """Every strongly connected set of two or more modules (each imports the others, through
    others or directly), sorted; Tarjan's algorithm, iteratively."""
    index, low, on_stack, stack, circles, counter = {}, {}, set(), [], [], [0]
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter[0]
                    counter[0] += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    circles.append(sorted(component))
    return sorted(circles)


def test_no_import_circle():
    circles = import_circles(import_graph(dict(_modules())))
    assert not circles, "modules that import each other (through others or directly):\n" + \
        "\n".join(" <-> ".join(c) for c in circles)


def test_the_circle_checker_sees_a_circle(tmp_path):
    # the test itself can fail: a circle through a function-level import, over three modules
    files = {"tankcd_cli.a": "from tankcd_cli.b import f\n", "tankcd_cli.b": "def f():\n    import tankcd_cli.c\n",
             "tankcd_cli.c": "from tankcd_cli import a\n", "tankcd_cli.d": "from tankcd_cli.a import x\n"}
    sources = {}
    for name, text in files.items():
        sources[name] = tmp_path / (name.rsplit(".", 1)[1] + ".py")
        sources[name].write_text(text)
    sources["tankcd_cli"] = tmp_path / "__init__.py"
    sources["tankcd_cli"].write_text("")
    assert import_circles(import_graph(sources)) == [["tankcd_cli.a", "tankcd_cli.b", "tankcd_cli.c"]]



def part_graph(graph: dict) -> dict:
    """{part: the other parts its modules import}, a part being the package's first level
    (``tankcd_cli.replay``, ``tankcd_cli.plots``): two parts whose modules import each other are one
    room drawn as two, even when no module circle joins them."""
    part = lambda module: ".".join(module.split(".")[:2])  # noqa: E731
    parts = {}
    for module, edges in graph.items():
        parts.setdefault(part(module), set()).update(part(t) for t in edges if part(t) != part(module))
    return parts


def test_no_two_parts_import_each_other():
    circles = import_circles(part_graph(import_graph(dict(_modules()))))
    assert not circles, "parts that import each other:\n" + "\n".join(" <-> ".join(c) for c in circles)


def test_the_part_checker_sees_parts_import_each_other():
    # replay.drawing -> plots -> replay.effects: no module circle, but the parts circle
    graph = {"tankcd_cli.plots": {"tankcd_cli.replay.effects"}, "tankcd_cli.replay.drawing": {"tankcd_cli.plots"},
             "tankcd_cli.replay.effects": set()}
    assert import_circles(graph) == []
    assert import_circles(part_graph(graph)) == [["tankcd_cli.plots", "tankcd_cli.replay"]]

# --- private names --------------------------------------------------------------------------

def private_imports(sources: dict) -> list:
    """Imports of another module's private names: ``from x import _y`` where x is another package
    module, and a compiled module (``pkg/_name``) imported by any module but its wrapper
    (``pkg/name``) -- a Cython ``cimport`` of its declarations (.pxd) excepted."""
    found = []
    for name, path in sources.items():
        for target, names, line, cimport in _import_statements(path):
            if not target.startswith("tankcd_cli"):
                continue
            where = f"{path.name}:{line}: {name}"
            for n in names:
                if n.startswith("_") and not n.startswith("__") and target != name:
                    found.append(f"{where} imports {n} from {target}")
            private = [p for p in target.split(".")[1:] if p.startswith("_") and not p.startswith("__")]
            wrapper = ".".join(target.split(".")[:-1] + [target.split(".")[-1].lstrip("_")])
            if private and not cimport and target != name and name != wrapper:
                found.append(f"{where} imports the private module {target} (only {wrapper} may)")
    return found


def test_no_private_name_is_imported_from_another_module():
    found = private_imports(dict(_modules()))
    assert not found, "private names imported from other modules:\n" + "\n".join(found)


def test_the_private_name_checker_sees_them(tmp_path):
    # the test itself can fail: a private function, a compiled module outside its wrapper
    cases = {
        "tankcd_cli.terrain.grid.store": ("from tankcd_cli.terrain.store import _open, open_store\n", 1),
        "tankcd_cli.terrain.mesh.surface": ("def f():\n    from tankcd_cli.terrain.grid._post_queries import full_cell\n", 1),
        "tankcd_cli.terrain.grid.post_queries": ("from tankcd_cli.terrain.grid._post_queries import (\n    full_cell,\n)\n", 0),
        "tankcd_cli.terrain.grid._post_queries": ("from tankcd_cli.terrain._post_cell cimport full_cell_c\n", 0),
        "tankcd_cli.bvh._traverse": ("from tankcd_cli.geometry._triangles cimport _pymax, tri_tri_c\n", 1),
    }
    for name, (text, expected) in cases.items():
        suffix = ".pyx" if name.rsplit(".", 1)[1].startswith("_") else ".py"
        path = tmp_path / (name.replace(".", "_") + suffix)
        path.write_text(text)
        assert len(private_imports({name: path})) == expected, (name, private_imports({name: path}))
