"""The package's imports point one way: no import circle between its modules, call-time imports included.

The graph is read from the source with :mod:`ast`, as a linter would: every
``import`` and ``from ... import`` of a module, at module level and inside
functions and methods, relative imports resolved. ``from .pkg import name``
points at ``pkg.name`` when that is a module of the package, else at ``pkg``
(its ``__init__``). Importing a submodule also runs its parent packages'
``__init__``, which the graph leaves out (every module would then depend on
``sindybench/__init__``, which gathers the public names).
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "sindybench"  # read, not imported
PACKAGE = "sindybench"


def module_names(root=ROOT, package=PACKAGE):
    """``{dotted name: path}`` of every module of the package (a package is its ``__init__``)."""
    names = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names[".".join([package, *parts])] = path
    return names


def _resolve(module, is_package, level, target):
    """The absolute name of ``from <level dots><target> import ...`` written in ``module``."""
    if level == 0:
        return target
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([target] if target else []))


def imports_of(module, path, modules):
    """The modules of the package that ``module`` imports (anywhere in its source), with the first line of each."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    found = {}

    def add(name, line):
        while name and name not in modules:  # sindybench.x.y.attr -> sindybench.x.y
            name = name.rpartition(".")[0]
        if name and name != module:
            found.setdefault(name, line)

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == PACKAGE:
                    add(alias.name, node.lineno)
        elif isinstance(node, ast.ImportFrom):
            base = _resolve(module, is_package, node.level, node.module)
            if base.split(".")[0] != PACKAGE:
                continue
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                add(sub if sub in modules else base, node.lineno)
    return found


def import_graph(root=ROOT, package=PACKAGE):
    modules = module_names(root, package)
    return {name: imports_of(name, path, modules) for name, path in modules.items()}


def find_cycles(graph):
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
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
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def one_circle(graph, component):
    """A shortest circle through the first module of ``component``, as ``a -> b -> ... -> a``."""
    members, start = set(component), component[0]
    previous, frontier = {start: None}, [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v]):
                if w == start:
                    path = [v]
                    while previous[path[-1]] is not None:
                        path.append(previous[path[-1]])
                    return [start, *reversed(path[:-1]), start] if len(path) > 1 else [start, v, start]
                if w in members and w not in previous:
                    previous[w] = v
                    nxt.append(w)
        frontier = nxt
    return component


def describe(graph, component):
    circle = one_circle(graph, component)
    steps = [f"{a} (line {graph[a][b]}) -> {b}" for a, b in zip(circle, circle[1:])]
    return f"{len(component)} modules in one circle, e.g.\n  " + "\n  ".join(steps)


def test_the_package_has_no_import_circle():
    graph = import_graph()
    assert len(graph) > 100  # the whole package was read
    cycles = find_cycles(graph)
    assert not cycles, "import circles (call-time imports included):\n" + "\n".join(describe(graph, c)
                                                                                      for c in cycles)


def _write(root, files):
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_a_call_time_import_closing_a_circle_is_found(tmp_path):
    """The check reads imports inside functions and resolves relative ones: a made-up package with one circle."""
    root = tmp_path / "sindybench"
    _write(root, {
        "__init__.py": "from ._a import f\n",
        "_a.py": "from .sub._b import g\n\ndef f():\n    return g()\n",
        "sub/__init__.py": "",
        "sub/_b.py": "def g():\n    from .. import _c\n    return _c.h()\n",
        "_c.py": "def h():\n    from ._a import f\n    return f\n",
        "_d.py": "import sindybench._c\n",  # points into the circle, not part of it
    })
    graph = import_graph(root)
    assert graph["sindybench.sub._b"] == {"sindybench._c": 2}
    cycles = find_cycles(graph)
    assert cycles == [["sindybench._a", "sindybench._c", "sindybench.sub._b"]]
    text = describe(graph, cycles[0])
    assert "sindybench._a (line 1) -> sindybench.sub._b" in text and "sindybench._c (line 2) -> sindybench._a" in text


@pytest.mark.parametrize("source, expected", [
    ("from . import _c\n", {"sindybench._c"}),
    ("from ._c import name\n", {"sindybench._c"}),
    ("from .sub import _b\n", {"sindybench.sub._b"}),
    ("from .sub import something\n", {"sindybench.sub"}),
    ("import sindybench.sub._b as b\n", {"sindybench.sub._b"}),
    ("import numpy\nfrom os import path\n", set()),
])
def test_imports_are_resolved_to_modules_of_the_package(tmp_path, source, expected):
    root = tmp_path / "sindybench"
    _write(root, {"__init__.py": "", "_a.py": source, "_c.py": "", "sub/__init__.py": "", "sub/_b.py": ""})
    assert set(import_graph(root)["sindybench._a"]) == expected
