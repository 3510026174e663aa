"""The benchmark scripts cannot rot: every one imports, every name it takes from tankcd_cli (at the
top, inside its functions, or in the worker code it hands to a child process) exists, and the cheap
ones run end to end at their smallest size.

The scripts' own full runs take minutes to hours; these checks take seconds. Peers that are not
installed (embree, fcl, coal, opendis, libigl, ...) are skipped, never failed: the scripts time
tankcd against them only where they are there.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BENCH = os.path.join(ROOT, "benchmarks")
SCRIPTS = sorted(f for f in os.listdir(BENCH) if f.endswith(".py"))

# optional peers a script times tankcd against: absent ones are not failures
PEERS = {"embreex", "embree", "pyembree", "fcl", "coal", "hppfcl", "opendis", "igl", "numba", "trimesh",
         "distributed", "dask", "rasterio", "h5py", "matplotlib", "pyproj", "scipy", "pyarrow", "meshio"}


@dataclass
class Imports:
    """What one script takes from elsewhere: (module, name or None, line) triples, and the
    attributes it reads off modules it imported by name: (module, attribute, line)."""

    names: list[tuple[str, str | None, int]] = field(default_factory=list)
    attributes: list[tuple[str, str, int]] = field(default_factory=list)


def _code_blocks(tree: ast.AST) -> list[ast.AST]:
    """The script and the Python source it holds in string constants (the worker code a script
    writes out for a child process), each parsed."""
    blocks = [tree]
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and "import " in node.value:
            try:
                blocks.append(ast.parse(node.value))
            except SyntaxError:
                pass
    return blocks


def _imports(path: str) -> Imports:
    with open(path) as fh:
        tree = ast.parse(fh.read(), path)
    out = Imports()
    for block in _code_blocks(tree):
        bound: dict[str, str] = {}  # a local name -> the module path it may be
        for node in ast.walk(block):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    out.names.append((alias.name, None, node.lineno))
                    if alias.asname:
                        bound[alias.asname] = alias.name
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                for alias in node.names:
                    out.names.append((node.module, alias.name, node.lineno))
                    bound[alias.asname or alias.name] = f"{node.module}.{alias.name}"
        for node in ast.walk(block):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound
                    and bound[node.value.id].startswith("tankcd_cli.")):
                out.attributes.append((bound[node.value.id], node.attr, node.lineno))
    return out


def _installed(module: str) -> bool:
    try:
        return importlib.util.find_spec(module.split(".")[0]) is not None
    except (ImportError, ValueError):
        return False


def _resolve(module: str, name: str | None):
    """The object ``from module import name`` (or ``import module``) binds; raises what Python would."""
    mod = importlib.import_module(module)
    if name is None or name == "*":
        return mod
    if hasattr(mod, name):
        return getattr(mod, name)
    return importlib.import_module(f"{module}.{name}")


@pytest.fixture
def bench_path(monkeypatch):
    monkeypatch.syspath_prepend(BENCH)
    monkeypatch.syspath_prepend(ROOT)


@pytest.mark.parametrize("script", SCRIPTS)
def test_every_name_a_script_imports_exists(script, bench_path):
    found = _imports(os.path.join(BENCH, script))
    missing = []
    for module, name, line in found.names:
        top = module.split(".")[0]
        own = top == "tankcd_cli" or os.path.exists(os.path.join(BENCH, top + ".py"))
        if not own:
            if not _installed(module) and top not in PEERS:
                missing.append(f"line {line}: {module} is not installed and is not an optional peer")
            continue
        try:
            _resolve(module, name)
        except (ImportError, AttributeError) as exc:
            missing.append(f"line {line}: from {module} import {name}: {exc}")
    for module, attr, line in found.attributes:
        try:
            obj = _resolve(*module.rsplit(".", 1))
        except (ImportError, AttributeError):
            continue  # reported above
        if isinstance(obj, type(os)) and not hasattr(obj, attr):
            try:
                importlib.import_module(f"{module}.{attr}")
            except ImportError:
                missing.append(f"line {line}: {module} has no {attr}")
    assert not missing, f"{script}:\n" + "\n".join(missing)


@pytest.mark.parametrize("script", SCRIPTS)
def test_every_script_imports(script, bench_path):
    name = os.path.splitext(script)[0]
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", os.path.join(BENCH, script))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # the top level only: main() runs under __name__ == "__main__"
    if name.startswith("bench_"):
        assert callable(getattr(module, "main", None)), f"{script} has no main()"


# the scripts that run end to end in a few seconds at their smallest size (the others take a minute
# or more even so: they are held to the import checks above)
SMOKE = {
    "bench_dis.py": ["--tanks", "2", "--hz", "1", "--seconds", "5", "--opendis-pdus", "5", "--repeat", "1"],
    "bench_parquet.py": ["--rows", "1000", "--repeat", "1"],
    "bench_internal.py": [],
    "bench_jet.py": ["--sizes", "1000", "--repeats", "1"],
    "bench_exercise.py": ["--vehicles", "2", "--minutes", "0.1", "--hz", "1", "--repeat", "1"],
}


@pytest.mark.parametrize("script", sorted(SMOKE))
def test_the_cheap_scripts_run_at_their_smallest_size(script, tmp_path):
    out = tmp_path / "report.md"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]))
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, os.path.join(BENCH, script), *SMOKE[script], "--out", str(out)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, f"{script} failed after {time.perf_counter() - start:.1f} s:\n{proc.stderr[-3000:]}"
    assert out.read_text().startswith("# "), f"{script} wrote no report"
