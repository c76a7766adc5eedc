"""Every module of the package imports in a fresh interpreter, in any order, and no two
modules import each other (directly or round a longer circle)."""

import ast
import importlib
import random
import subprocess
import sys
from pathlib import Path

import pytest

import diskpack_cl
from diskpack_cl.moved import MOVED

PACKAGE = Path(diskpack_cl.__file__).parent


def _modules():
    """``{module name: path}`` of every module of the package, subpackages included."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()
#: What an import may run: not ``__main__`` (the ``python -m`` script runs the command).
IMPORTABLE = sorted(m for m in MODULES if not m.endswith(".__main__"))
ORDERS = {"sorted": IMPORTABLE, "reversed": IMPORTABLE[::-1],
          **{f"shuffled {seed}": random.Random(seed).sample(IMPORTABLE, len(IMPORTABLE))
             for seed in (1, 2, 3)}}


@pytest.mark.parametrize("order", ORDERS)
def test_every_module_imports_in_a_fresh_interpreter(order):
    names = ORDERS[order]
    code = "import importlib, sys\nfor name in sys.argv[1:]:\n    importlib.import_module(name)"
    proc = subprocess.run([sys.executable, "-c", code, *names], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]


def _targets(module, path, node):
    """The package's modules an import statement of `module` names."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    if isinstance(node, ast.Import):
        found = [alias.name for alias in node.names]
    else:
        base = node.module or ""
        if node.level:
            parts = package.split(".")[: len(package.split(".")) - node.level + 1]
            base = ".".join(parts + ([node.module] if node.module else []))
        # `from pkg import mod` names the module, `from mod import name` the module itself
        found = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base
                 for alias in node.names]
    out = set()
    for name in found:
        while name and name not in MODULES:
            name = name.rpartition(".")[0]
        if name and name != module:
            out.add(name)
    return out


def import_graph():
    """``{module: {imported module: [line, ...]}}``, counting the imports inside functions:
    they close a circle as well, only later."""
    graph = {}
    for module, path in MODULES.items():
        edges = graph.setdefault(module, {})
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for target in _targets(module, path, node):
                    edges.setdefault(target, []).append(node.lineno)
    return graph


def circles(graph):
    """The strongly connected components of more than one module (Tarjan), sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def test_circles_finds_a_circle_round_three_modules():
    graph = {"a": {"b": [1]}, "b": {"c": [1]}, "c": {"a": [1]}, "d": {"a": [1]}}
    assert circles(graph) == [["a", "b", "c"]]


def test_the_package_has_no_import_circle():
    graph = import_graph()
    found = circles(graph)
    described = [" <-> ".join(c) + ": " + "; ".join(
        f"{a} imports {b} (line {', '.join(map(str, graph[a][b]))})"
        for a in c for b in sorted(graph[a]) if b in c) for c in found]
    assert not found, "\n".join(described)


def private_imports(module, path):
    """``[(line, imported module, name)]``: the private names (``_x``) that `module` takes
    from another module of the package; a private *module* (``from . import _timing``) is
    a module, not a name, and may be imported."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.ImportFrom):
            continue
        for alias in node.names:
            private = alias.name.startswith("_") and not alias.name.startswith("__")
            targets = _targets(module, path, ast.ImportFrom(node.module, [alias], node.level))
            if private and targets and not any(t.endswith("." + alias.name) for t in targets):
                found.append((node.lineno, sorted(targets)[0], alias.name))
    return found


def test_private_imports_finds_a_private_name_and_passes_a_private_module(tmp_path):
    path = tmp_path / "mod.py"
    path.write_text("from .stipple import _run, run\nfrom . import _timing\n")
    assert private_imports("diskpack_cl.mod", path) == [(1, "diskpack_cl.stipple", "_run")]


def test_no_private_name_crosses_a_module():
    found = [f"{module}:{line} takes {name} from {target}"
             for module, path in MODULES.items()
             for line, target, name in private_imports(module, path)]
    assert not found, "\n".join(found)


def kernel_home(stem, modules):
    """The module a kernel file's stem names: the longest of its ``_``-prefixes that is a
    module's name (``raster_labels`` -> ``raster``), or None."""
    parts = stem.split("_")
    by_name = {m.rpartition(".")[2]: m for m in modules}
    for end in range(len(parts), 0, -1):
        if "_".join(parts[:end]) in by_name:
            return by_name["_".join(parts[:end])]
    return None


def test_kernel_home_takes_the_longest_prefix():
    modules = ["p.device.cells", "p.device.cells3", "p.parallel_darts"]
    assert kernel_home("cells_nearest", modules) == "p.device.cells"
    assert kernel_home("cells3", modules) == "p.device.cells3"
    assert kernel_home("parallel_darts", modules) == "p.parallel_darts"
    assert kernel_home("power_diagram", modules) is None


def test_every_kernel_is_named_for_the_module_that_builds_it():
    from diskpack_cl.device.programs import kernel_dir

    wrong = []
    for path in sorted(kernel_dir().glob("*.cl")):
        home = kernel_home(path.stem, MODULES)
        if home is None or f'"{path.stem}"' not in MODULES[home].read_text():
            wrong.append(f"{path.name}: named for {home}, which does not build it")
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_module_name_gives_the_new_module_with_a_warning(old):
    sys.modules.pop(old, None)
    try:
        with pytest.warns(DeprecationWarning, match=f"{old} moved to {MOVED[old]}"):
            module = importlib.import_module(old)
        assert module is importlib.import_module(MOVED[old])
        assert module.__spec__.name == MOVED[old]   # its relative imports still resolve
    finally:
        sys.modules.pop(old, None)
