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
                ours = imported.split(".")[0] in {"bkflow", "benchmarks", "tests"} | \
                    _scripts()
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


def _every_module() -> dict[str, Path]:
    """``_modules`` and the tests' (a package), and the workflows' scripts by their file
    names (they import each other so)."""
    out = dict(_modules())
    for p in (ROOT / "tests").rglob("*.py"):
        parts = p.relative_to(ROOT).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    out.update((p.stem, p) for p in (ROOT / "workflows").rglob("*.py"))
    return out


def test_no_import_circle_anywhere():
    """No circle among the modules of the package, the benchmarks, the tests and the
    workflows."""
    found = circles(import_graph(_every_module()))
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
    """A module of this repository: bkflow's, the benchmarks' or the tests' (packages), or a
    script of workflows/ (which import each other by their file names)."""
    return module.split(".")[0] in {"bkflow", "benchmarks", "tests"} | _scripts()


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


def test_no_test_module_takes_another_test_modules_private_name():
    """What tests share is a public name of a helper module (tests/support.py,
    tests/figures/reading.py), not a private one of another test file."""
    tests = ROOT / "tests"
    found = [f for p in sorted(tests.rglob("*.py")) for f in private_imports(p)
             if f.split(": ")[1].startswith("tests.")]
    assert found == [], "private names of other test modules: " + "; ".join(found)


def test_the_private_name_check_finds_what_it_looks_for(tmp_path):
    p = tmp_path / "user.py"
    p.write_text("from bkflow.figures import style\nfrom bkflow.figures.data import _x, y\n"
                 "import claims\n\ndef f():\n    return style._num(1), claims._sem, y._z\n")
    assert sorted(f.split(": ")[1] for f in private_imports(p)) == [
        "bkflow.figures.data._x", "claims._sem", "style._num", "y._z"]
    p.write_text("from bkflow import __version__\nimport os\nos._exit\n")
    assert private_imports(p) == []


#: the faces that hand names on by design: the package's own (``import bkflow``), the SLURM
#: path's command module (``python -m bkflow.slurm``) and its old name (``bkflow.cluster``),
#: and the documented path of the figures' catalogue and writer (docs/api.md before they were
#: two modules)
FACES = {"bkflow", "bkflow.slurm", "bkflow.cluster", "bkflow.figures.registry"}


def _top_level(path: Path) -> tuple[set[str], dict[str, str]]:
    """The names a module defines at its top level, and those it imports (name: module)."""
    defined, imported = set(), {}
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            defined.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                defined |= {n.id for n in ast.walk(target) if isinstance(n, ast.Name)}
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported.update({a.asname or a.name: node.module for a in node.names})
    return defined, imported


def handed_on(paths, modules) -> list[str]:
    """Where a file takes a name from a bkflow module that only imported it (a re-export):
    ``from m import X`` or ``m.X`` with X imported, not defined, by m."""
    tops = {name: _top_level(path) for name, path in modules.items()}

    def relayed(module: str, name: str) -> bool:
        if module not in tops or module in FACES or f"{module}.{name}" in modules:
            return False
        defined, imported = tops[module]
        return name in imported and name not in defined

    found = []
    for path in paths:
        tree = ast.parse(path.read_text())
        alias = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                for a in node.names:
                    if relayed(node.module, a.name):
                        found.append(f"{path.name}:{node.lineno}: {node.module}.{a.name}")
                    if f"{node.module}.{a.name}" in modules:
                        alias[a.asname or a.name] = f"{node.module}.{a.name}"
            elif isinstance(node, ast.Import):
                alias.update({a.asname: a.name for a in node.names
                              if a.asname and a.name in modules})
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and \
                    node.value.id in alias and relayed(alias[node.value.id], node.attr):
                found.append(f"{path.name}:{node.lineno}: {alias[node.value.id]}.{node.attr}")
    return found


def test_every_name_is_imported_from_where_it_lives():
    """No module hands on another's names (a re-export): every import names the module that
    defines the name, in the package, the tests, the benchmarks and the workflows."""
    root = SRC.parent.parent
    paths = [p for d in (*CODE, root / "tests") for p in sorted(d.rglob("*.py"))]
    found = handed_on(paths, _modules())
    assert found == [], "names imported from a module that only handed them on: " + \
        "; ".join(found)


def test_the_reexport_check_finds_what_it_looks_for(tmp_path):
    mods = {"bkflow.a": tmp_path / "a.py", "bkflow.b": tmp_path / "b.py"}
    mods["bkflow.a"].write_text("X = 1\n")
    mods["bkflow.b"].write_text("from bkflow.a import X\nY = X\n")
    user = tmp_path / "user.py"
    user.write_text("from bkflow.a import X\nfrom bkflow.b import X, Y\nfrom bkflow import b\n"
                    "b.X, b.Y\n")
    assert sorted(f.split(": ")[1] for f in handed_on([user], mods)) == ["bkflow.b.X",
                                                                         "bkflow.b.X"]


def test_the_documented_faces_still_answer():
    """Code written against the old documented path of ``bkflow plot``'s catalogue and writer
    gets the same objects."""
    from bkflow.figures import catalogue, registry, writer

    assert (registry.plot, registry.save_figure, registry.FORMATS) == \
        (writer.plot, writer.save_figure, writer.FORMATS)
    assert (registry.figure, registry.FIGURES, registry.FigureSpec) == \
        (catalogue.figure, catalogue.FIGURES, catalogue.FigureSpec)
