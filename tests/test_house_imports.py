"""The house's import graph: no module imports one that (through others) imports it back,
lazy imports and ``__main__`` blocks included (graphlib finds the circles); and no module
takes another's private (underscore) name: what modules share has a public name."""

from __future__ import annotations

import ast
import functools
import graphlib
from collections import defaultdict
from pathlib import Path

import bkflow

SRC = Path(bkflow.__file__).parent
ROOT = Path(__file__).resolve().parents[1]
#: the code held to the house's rules: the package, the benchmarks and the workflows
CODE = (SRC, ROOT / "benchmarks", ROOT / "workflows")


def _modules() -> dict[str, Path]:
    """bkflow's modules and the benchmarks' by dotted name (a package by its own name)."""
    out = {}
    for top in (SRC, ROOT / "benchmarks"):
        for p in top.rglob("*.py"):
            parts = p.relative_to(top.parent).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    return out


def _target(name: str, modules) -> str | None:
    """The module an imported dotted name lives in (``a.b.c`` a name of ``a.b``)."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def import_graph(modules) -> dict[str, set[str]]:
    """Every module's imports of the others (bkflow's and the benchmarks'), anywhere in it; a
    package's import of its own parent (``from bkflow import __version__``) is not a circle."""
    graph = defaultdict(set)
    for name, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            for imported in names:
                ours = imported.split(".")[0] in ("bkflow", "benchmarks")
                to = _target(imported, modules) if ours else None
                if to and to != name and not name.startswith(to + "."):
                    graph[name].add(to)
    return graph


def circles(graph) -> list[list[str]]:
    """The import circles of ``graph``: one found by graphlib, its last edge taken out, and
    again, until none is left."""
    graph = {k: set(v) for k, v in graph.items()}
    found = []
    while True:
        try:
            graphlib.TopologicalSorter(graph).prepare()
            return found
        except graphlib.CycleError as exc:
            cycle = exc.args[1]   # [a, b, ..., a]: each in the graph of the one after it
            found.append(cycle)
            graph[cycle[1]].discard(cycle[0])


def test_no_import_circle_anywhere():
    found = circles(import_graph(_modules()))
    assert found == [], "import circles: " + "; ".join(" -> ".join(c) for c in found)


def test_the_circle_check_finds_a_circle(tmp_path):
    """A made-up package whose module imports, in a function and under ``__main__``, the one
    that imports it."""
    mods = {"bkflow.a": tmp_path / "a.py", "bkflow.b": tmp_path / "b.py",
            "bkflow.c": tmp_path / "c.py"}
    mods["bkflow.a"].write_text("from bkflow.b import f\n")
    mods["bkflow.b"].write_text("def f():\n    from bkflow.c import g\n")
    mods["bkflow.c"].write_text("if __name__ == '__main__':\n    import bkflow.a\n")
    found = circles(import_graph(mods))
    assert len(found) == 1 and set(found[0]) == set(mods)
    mods["bkflow.c"].write_text("from bkflow import __version__\n")
    assert circles(import_graph(mods)) == []


@functools.cache
def _scripts() -> frozenset[str]:
    return frozenset(p.stem for p in (ROOT / "workflows").rglob("*.py"))


def _ours(module: str) -> bool:
    """A module of this repository: bkflow's, the benchmarks' (a package), or a script of
    workflows/ (which import each other by their file names)."""
    return module.split(".")[0] in {"bkflow", "benchmarks"} | _scripts()


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_imports(path: Path) -> list[str]:
    """Where ``path`` takes a private name of another module of ours: ``from m import _x``,
    or ``m._x`` of a module ``m`` it imported."""
    tree = ast.parse(path.read_text())
    found, modules = [], set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and _ours(node.module):
            found += [f"{path.name}:{node.lineno}: {node.module}.{a.name}"
                      for a in node.names if _private(a.name)]
            modules |= {a.asname or a.name for a in node.names if not _private(a.name)}
        elif isinstance(node, ast.Import):
            modules |= {a.asname or a.name.split(".")[0] for a in node.names if _ours(a.name)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr) and \
                isinstance(node.value, ast.Name) and node.value.id in modules:
            found.append(f"{path.name}:{node.lineno}: {node.value.id}.{node.attr}")
    return found


def test_no_private_name_is_taken_across_modules():
    found = [f for d in CODE for p in sorted(d.rglob("*.py")) for f in private_imports(p)]
    assert found == [], "private names taken across modules: " + "; ".join(found)


def test_the_private_name_check_finds_what_it_looks_for(tmp_path):
    p = tmp_path / "user.py"
    p.write_text("from bkflow.figures import style\nfrom bkflow.figures.data import _x, y\n"
                 "import claims\n\ndef f():\n    return style._num(1), claims._sem, y._z\n")
    assert sorted(f.split(": ")[1] for f in private_imports(p)) == [
        "bkflow.figures.data._x", "claims._sem", "style._num", "y._z"]
    p.write_text("from bkflow import __version__\nimport os\nos._exit\n")
    assert private_imports(p) == []
