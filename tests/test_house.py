"""The house: who imports whom, the run directory's checks, flow's internals, and analysis as
a step that is redone from a run's files (no LAMMPS) when its settings change."""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

import pandas as pd
import pytest

import bkflow
from bkflow.cli.assignments import analysis_assignments
from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec
from bkflow.model.settings import AnalysisSettings
from bkflow.store.layout import META
from bkflow.store.rundir import RunDir

SRC = Path(bkflow.__file__).parent
ROOT = Path(__file__).resolve().parents[1]

#: the layers of the package, bottom to top (docs/develop.md, "Layout"): a module imports
#: modules of its own group and of groups below it, never one above. The faces at the top
#: (``bkflow/__init__.py``, ``bkflow/slurm.py`` and its old name ``bkflow/cluster.py``) only
#: hand names on.
LAYERS = ("model", "observables", "store", "lammps", "analysis", "sweeps", "figures", "api",
          "cli", "slurm", "cluster")
#: what each group is for, in the words of its __init__
GROUPS = ("model", "observables", "store", "lammps", "analysis", "sweeps", "figures", "cli")


def _group(path: Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def _bkflow_imports(path: Path) -> set[str]:
    """The groups of bkflow a source file imports, anywhere in it (lazy imports included)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}:{node.lineno}: a relative import; name the group"
            if node.module and node.module.startswith("bkflow."):
                found.add(node.module.split(".")[1])
        elif isinstance(node, ast.Import):
            found.update(a.name.split(".")[1] for a in node.names
                         if a.name.startswith("bkflow."))
    return found - {"__init__"}


MODULES = sorted(p for p in SRC.rglob("*.py") if p.name not in ("__init__.py", "__main__.py"))


def test_every_module_belongs_to_a_layer():
    loose = [str(p.relative_to(SRC)) for p in MODULES if _group(p) not in LAYERS]
    assert not loose, f"place these in a group of LAYERS (and docs/develop.md): {loose}"
    for group in GROUPS:
        doc = ast.get_docstring(ast.parse((SRC / group / "__init__.py").read_text()))
        assert doc, f"bkflow.{group} says in its __init__ what it is for"


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_no_module_imports_a_layer_above_its_own(path):
    group = _group(path)
    above = set(LAYERS[LAYERS.index(group) + 1:])
    wrong = _bkflow_imports(path) & above
    assert not wrong, f"{path.relative_to(SRC)} ({group}) imports {sorted(wrong)}, above it"


def test_observables_are_pure_numerics():
    """Arrays in, arrays out: no files, no LAMMPS, no flow."""
    for path in (SRC / "observables").glob("*.py"):
        assert _bkflow_imports(path) <= {"model", "observables"}, path.name
        text = path.read_text()
        for lib in ("lammps", "signac", "flow"):
            assert f"import {lib}" not in text and f"from {lib} " not in text, (path.name, lib)


def test_figures_never_analyse_and_never_need_flow():
    """Figures read tables; of the analysis only the summary keys' declarations (which keys an
    observable draws, their units)."""
    for path in (SRC / "figures").glob("*.py"):
        assert not _bkflow_imports(path) & {"lammps", "sweeps"}, path.name
        tree = ast.parse(path.read_text())
        analysis = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                    and n.module and n.module.startswith("bkflow.analysis")}
        analysis |= {f"{n.module}.{a.name}" for n in ast.walk(tree)
                     if isinstance(n, ast.ImportFrom) and n.module == "bkflow.analysis"
                     for a in n.names}
        assert analysis <= {"bkflow.analysis", "bkflow.analysis.summary_keys"}, (path.name,
                                                                                 analysis)
        text = path.read_text()
        assert "import flow" not in text and "from flow" not in text
        assert "import signac" not in text and "signac_project_document" not in text, path.name


#: the limits a maintainer can read a file and a function within (docs/develop.md, "Layout")
MAX_LINES, MAX_COMPLEXITY = 500, 15
#: a function above MAX_COMPLEXITY says why in the comment right above it (above its
#: decorators or template line), a comment that names its complexity
WHY_COMPLEX = "complexity"


#: the Python held to those limits beside the benchmarks: the package and the workflows
LIMITED = (SRC, ROOT / "workflows")


def _sources():
    """The code held to the limits: the package, the workflows, the plugin and the
    benchmarks."""
    return sorted([*(p for root in LIMITED for p in root.rglob("*.py")),
                   *(ROOT / "plugins").glob("*.[ch]*"), *(ROOT / "plugins").glob("*.inc"),
                   *(ROOT / "benchmarks").rglob("*.py"), *(ROOT / "benchmarks").rglob("*.c")])


def test_no_file_over_500_lines():
    long = [f"{p.relative_to(ROOT)}: {n}" for p in _sources()
            if (n := len(p.read_text().splitlines())) > MAX_LINES]
    assert not long, f"split these by what they do (at most {MAX_LINES} lines): {long}"


def _says_why(lines: list[str], start: int) -> bool:
    """Whether the comment right above line ``start`` (counted from 1; above decorators and a
    C++ template line) names the function's complexity."""
    i = start - 2
    while i >= 0 and lines[i].lstrip().startswith(("@", "template", "__attribute__")):
        i -= 1
    comment = []
    if i >= 0 and lines[i].rstrip().endswith("*/"):       # a block comment: up to its start
        while i >= 0 and "/*" not in lines[i]:
            comment.append(lines[i])
            i -= 1
        comment.append(lines[i] if i >= 0 else "")
    else:                                                  # line comments
        while i >= 0 and lines[i].lstrip().startswith(("#", "//")):
            comment.append(lines[i])
            i -= 1
    return WHY_COMPLEX in " ".join(comment).lower()


def test_no_function_over_complexity_15_without_a_reason():
    lizard = pytest.importorskip("lizard")
    bad = []
    for p in _sources():
        if p.suffix not in (".py", ".c", ".cpp", ".h", ".inc"):
            continue
        text = p.read_text()
        lines = text.splitlines()
        name = p.name if p.suffix != ".inc" else p.with_suffix(".cpp").name
        for f in lizard.analyze_file.analyze_source_code(name, text).function_list:
            if f.cyclomatic_complexity > MAX_COMPLEXITY and not _says_why(lines, f.start_line):
                bad.append(f"{p.relative_to(ROOT)}:{f.start_line} {f.name} "
                           f"({f.cyclomatic_complexity})")
    # and the check sees what it must: a reason above, or none
    assert _says_why(["# complexity: one loop", "@cache", "def f():"], 3)
    assert _says_why(["/* stays whole: its complexity", "   is the loop's */", "void f()"], 3)
    assert not _says_why(["# a plain comment", "def f():"], 2)
    assert not bad, ("split these, or say in a comment above them why their complexity "
                     "stays: " + "; ".join(bad))


def test_no_run_file_name_is_written_outside_rundir():
    names = ("in.bk", "data.bk", "params.json", "stress.csv", "phase.csv", "snapshots.lammpstrj",
             "slips.lammpstrj", "log.lammps", "meta.json", "summary.json", "events.csv",
             "events.parquet", "psi.csv", "clusters.csv", "extrema.npy", "blocks.npy",
             "psi.npy")
    for path in SRC.rglob("*.py"):
        if path.stem in ("layout", "rundir"):
            continue
        code = ast.parse(path.read_text())
        docstrings = {id(n.body[0].value) for n in ast.walk(code)
                      if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef))
                      and n.body and isinstance(n.body[0], ast.Expr)}
        for node in ast.walk(code):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and id(node) not in docstrings:
                hits = [n for n in names if n in node.value]
                assert not hits, f"{path.name}:{node.lineno} names {hits}: use bkflow.store.rundir"


#: calls that create or fill a file
WRITERS = {"write_text", "write_bytes", "savefig", "save", "to_csv", "to_json", "to_parquet",
           "savetxt", "savez", "dump", "touch", "write", "writelines", "mkstemp", "copy",
           "copyfile", "copy2", "move", "rename", "replace"}
#: the writes outside store/files.py that do not go through the atomic writer, and why
ALLOWED = {
    ("rundir.py", "touch"): "the empty marker that claims a new run directory",
    ("style.py", "savefig"): "a notebook's inline PNG, into an in-memory buffer",
    ("lock.py", "open"): "the lock file: created empty, locked (flock), never written",
    ("guards.py", "open"): "/dev/null, which stdout becomes when the reader of a pipe has gone "
                        "(and stdout or stderr when the caller closed them)",
    ("guards.py", "mkstemp"): "an internal error's traceback, in a new file of its own",
    ("rundir.py", "replace"): "a record kept whole (atomic_file) while a continuation rewrote "
                              "it in place, renamed back over it when the continuation is "
                              "undone",
}


def _writes(tree):
    """(call, inside `with atomic_file(...)`) for every writer call and every open() of a
    file for writing in a module."""
    out = []

    def visit(node, guarded):
        if isinstance(node, ast.With) and any(
                isinstance(i.context_expr, ast.Call)
                and getattr(i.context_expr.func, "id", getattr(i.context_expr.func, "attr", ""))
                == "atomic_file" for i in node.items):
            guarded = True
        if isinstance(node, ast.Call):
            f = node.func
            name = getattr(f, "attr", getattr(f, "id", ""))
            mode = [a.value for a in node.args[1:2] + [k.value for k in node.keywords
                                                         if k.arg == "mode"]
                    if isinstance(a, ast.Constant) and isinstance(a.value, str)]
            flags = ast.unparse(node) if name == "open" and isinstance(f, ast.Attribute) else ""
            if (name in WRITERS or (name == "open" and any(set(m) & set("wax+") for m in mode))
                    or "O_CREAT" in flags or "O_WRONLY" in flags):
                out.append((node, name, guarded))
        for child in ast.iter_child_nodes(node):
            visit(child, guarded)

    visit(tree, False)
    return out


def test_nothing_writes_a_users_file_except_through_the_atomic_writer():
    """A figure, a movie, a deck, a table: every file bkflow writes goes through
    bkflow.store.files.atomic_file (a temporary file renamed over the old one), so that
    SIGTERM, Ctrl-C or a full disk leaves the old file or the new one, never half of one. The
    only exceptions are named above with their reason, and LAMMPS's own outputs of a run
    under way (not Python's)."""
    bad = []
    for path in sorted(SRC.rglob("*.py")):
        if path.name == "files.py":   # atomic_file itself
            continue
        for node, name, guarded in _writes(ast.parse(path.read_text())):
            if guarded or (path.name, name) in ALLOWED:
                continue
            if name in ("write", "dump") and "file=" not in ast.unparse(node) and \
                    isinstance(node.func, ast.Attribute) and \
                    ast.unparse(node.func.value) in ("f", "fh", "sys.stdout", "sys.stderr"):
                continue  # writing to a handle atomic_file gave, or to a stream
            if name == "replace" and "os.replace" != ast.unparse(node.func) and \
                    "rename" not in ast.unparse(node.func):
                continue  # str.replace, dataclasses.replace, RunSpec.replace
            if name in ("copy", "move") and not ast.unparse(node.func).startswith("shutil"):
                continue  # dict.copy, array.copy
            if name == "dump" and ast.unparse(node.func) != "json.dump":
                continue
            bad.append(f"{path.name}:{node.lineno}: {ast.unparse(node)[:80]}")
    assert not bad, "writes that bypass files.atomic_file:\n" + "\n".join(bad)
    # and the check sees what it must: a bare write is caught
    probe = ast.parse("def f(fig, p):\n    fig.savefig(p)\n    open(p, 'w')\n"
                      "    with atomic_file(p, binary=True) as fh:\n        fig.savefig(fh)\n")
    assert [g for _, _, g in _writes(probe)] == [False, False, True]


def test_flow_internals_we_use_still_exist(tmp_path):
    from bkflow.sweeps.flowcompat import check
    from bkflow.sweeps.project import TEMPLATE_DIR, ClusterProject, open_project

    open_project(tmp_path)
    project = ClusterProject.get_project(str(tmp_path), search=False)
    check(project)
    assert project._template_dir == str(TEMPLATE_DIR) and (TEMPLATE_DIR / "script.sh").is_file()


# --------------------------------------------------------------------------- settings
def test_analysis_settings_defer_to_the_run_and_name_bad_values():
    spec = RunSpec(phi=1.0, slip_threshold=0.02, transient=0.3)
    r = AnalysisSettings().resolved(spec)
    assert (r.slip_threshold, r.transient) == (0.02, 0.3)
    assert AnalysisSettings(s_x=0.05).resolved(spec).s_x == 0.05
    s = analysis_assignments(["s_x=0.02", "report_thresholds=0.01,0.1"])
    assert s.s_x == 0.02 and s.report_thresholds == (0.01, 0.1)
    assert AnalysisSettings.from_dict(s.to_dict()) == s
    for bad, needle in ((["s_x=-1"], "s_x must be a number > 0"), (["sx=1"], "NAME one of"),
                        (["s_x=abc"], "not a number"), (["transient=1.5"], "[0, 1)")):
        with pytest.raises(SpecError, match=needle.replace("[", r"\[").replace(")", r"\)")):
            analysis_assignments(bad)


# --------------------------------------------------------------------------- re-analysis
def test_changing_an_analysis_setting_reanalyses_a_finished_sweep_without_lammps(
        lammps, tmp_path, monkeypatch):
    from bkflow.cli.commands import main
    from bkflow.lammps import engine
    from bkflow.store.tables import RESULTS_FILE, RUNS_FILE, SETTINGS_FILE
    from bkflow.sweeps import job
    from bkflow.sweeps.grid import sweep_specs
    from bkflow.sweeps.local import sweep
    from bkflow.sweeps.project import open_project

    out = tmp_path / "s"
    specs = sweep_specs([1.0, 1000.0], [(20, 5)], 1, t_end=300.0, scene="full")
    rep = sweep(specs, out, jobs=1, progress=False)
    assert len(rep.finished) == 2
    project = open_project(out, create=False)
    dirs = [RunDir(j.path) for j in project]
    before = {rd.path: (rd.file(META).read_bytes(), rd.summary()) for rd in dirs}

    def no_lammps(*args, **kwargs):
        raise AssertionError("LAMMPS ran")

    monkeypatch.setattr(engine, "run", no_lammps)
    monkeypatch.setattr(job, "run", no_lammps)
    assert main(["collect", str(out), "--analysis", "s_x=0.05"]) == 0
    for rd in dirs:
        meta, old = before[rd.path]
        assert rd.file(META).read_bytes() == meta           # no LAMMPS run
        new = rd.summary()
        assert new["settings"]["s_x"] == 0.05 and old["settings"]["s_x"] == 0.01
        assert new["mu_bar"] == old["mu_bar"]               # the stress is the same
        assert rd.analysis_problem(AnalysisSettings(s_x=0.05)) is None
    changed = [rd for rd in dirs if before[rd.path][1]["n_clusters"] != rd.summary()["n_clusters"]
               or before[rd.path][1]["lx_over_ly"] != rd.summary()["lx_over_ly"]]
    assert changed, "a five times larger S_x changed no cluster: the setting was not applied"
    runs = pd.read_csv(out / RUNS_FILE)
    res = pd.read_csv(out / RESULTS_FILE)
    for rd in dirs:
        s = rd.summary()
        row = runs[runs.job == rd.path.name].iloc[0]
        assert row.lx_over_ly == pytest.approx(s["lx_over_ly"], rel=1e-12)
        r = res[res.phi == s["params"]["phi"]].iloc[0]
        assert r.lx_over_ly == pytest.approx(s["lx_over_ly"], rel=1e-12)
    assert json.loads((out / SETTINGS_FILE).read_text())["s_x"] == 0.05
    # the same sweep again: everything current, nothing re-analysed or run
    rep = sweep(specs, out, jobs=1, progress=False)
    assert rep.finished_before == 2 and not rep.finished


def test_the_code_is_lint_clean():
    """ruff (pyproject.toml [tool.ruff]) finds nothing in the package, tests, benchmarks and
    workflows: the lint runs with the test suite, so CI runs it (and fails without ruff)."""
    import shutil
    import subprocess
    import sys

    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    if ruff is None:
        pytest.fail("ruff is not installed: pip install -e '.[test]' installs it")
    proc = subprocess.run([ruff, "check", "--no-cache", "src", "tests", "docs", "benchmarks",
                           "workflows"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_the_docs_site_builds_strictly(tmp_path):
    """mkdocs build --strict (mkdocs.yml): every page, link and API reference resolves."""
    import shutil
    import subprocess
    import sys

    mkdocs = shutil.which("mkdocs", path=str(Path(sys.executable).parent))
    if mkdocs is None:
        pytest.fail("mkdocs is not installed: pip install -e '.[test]' installs it")
    proc = subprocess.run([mkdocs, "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for page in ("index.html", "model/index.html", "cli/index.html", "api/index.html",
                 "benchmarks/RESULTS/index.html", "workflows/paper/REPRODUCTION/index.html"):
        assert (tmp_path / "site" / page).is_file(), page
    cli = (tmp_path / "site" / "cli" / "index.html").read_text()
    assert "--vary" in cli and "bkflow sweep" in cli
    unrendered = {}
    for page in sorted((tmp_path / "site").rglob("*.html")):
        found = unrendered_markup(page.read_text())
        if found:
            unrendered[str(page.relative_to(tmp_path / "site"))] = found[:3]
    assert not unrendered, unrendered


#: markup that shows literally on a page when a docstring or a page is not the Markdown that
#: mkdocs and mkdocstrings render: reST roles and literal-block markers, reST tables, a
#: double backtick left over, a Markdown table or emphasis that did not become HTML
UNRENDERED = [r":(?:py:)?(?:class|func|mod|data|attr|meth|exc|obj|ref|doc|math):",
              r"(?<![.:])::(?![:\w])", r"^\s*\.\. \w+::", r"={5,}", r"``", r"\|\s*---",
              r"(?<![\w*])\*\*\w[^*<]*\*\*"]


def unrendered_markup(html: str) -> list[str]:
    """What of ``html``'s text (code and scripts left out) is markup that was not rendered."""
    text = re.sub(r"<(pre|code|script|style)\b.*?</\1>", " ", html, flags=re.S)
    text = re.sub(r"<[^>]+>", " ", text)
    return [text[max(0, m.start() - 40):m.end() + 20].strip() for pat in UNRENDERED
            for m in re.finditer(pat, text, flags=re.M)]


def test_the_docs_show_an_image_of_every_figure():
    """docs/sweeps.md shows each figure ``bkflow plot`` draws, and the image is there."""
    from bkflow.figures.catalogue import FIGURES

    text = (ROOT / "docs" / "sweeps.md").read_text()
    for name in FIGURES:
        m = re.search(rf"!\[{name}\]\(([^)]+)\)", text)
        assert m, f"docs/sweeps.md shows no image of {name}"
        assert (ROOT / m.group(1)).is_file(), m.group(1)


def test_the_unrendered_markup_check_finds_what_it_looks_for():
    for raw in ("see :class:<code>RunSpec</code>", "<p>an example::</p>", "<p>``x``</p>",
                "<p>==========  =====</p>", "<p>| a | b |\n|---|---|</p>", "<p>**bold**</p>",
                "<p>.. note:: this</p>"):
        assert unrendered_markup(raw), raw
    for fine in ("<p>a <code>:class:</code> and <code>a::b</code></p>", "<p>1 .. 3</p>",
                 "<pre>==========</pre>", "<p>std::vector</p>", "<p>t = 0 ... 1</p>"):
        assert not unrendered_markup(fine), fine


def test_nothing_refers_outside_the_repository():
    """The model is the repository's own (docs/model.md): no code, test or document points
    to a file outside it."""
    roots = [ROOT / d for d in ("src", "plugins", "tests", "docs", "benchmarks", "workflows",
                                "lammps_inputs")] + [ROOT / "README.md"]
    hits = []
    # the directory beside the repository where the spec was read (spelt so that this file
    # does not match itself)
    needles = ["../" + "sha" + "red", "sha" + "red/MO" + "DEL"]
    for root in roots:
        files = [root] if root.is_file() else [p for p in root.rglob("*") if p.is_file()]
        for f in files:
            if f.suffix in (".png", ".pdf", ".so") or "__pycache__" in f.parts:
                continue
            try:
                text = f.read_text()
            except UnicodeDecodeError:
                continue
            if any(n in text for n in needles):
                hits.append(str(f.relative_to(ROOT)))
    assert not hits, hits


@pytest.mark.slow
def test_the_plugin_compiles_without_a_warning():
    """Every C++ source of plugins/ under -Wall -Wextra -Werror (syntax and semantic checks,
    no code generated), against the LAMMPS and MPI headers the install builds with."""
    import shutil
    import subprocess
    import sys

    cxx = shutil.which("g++") or shutil.which("c++")
    if cxx is None:
        pytest.fail("no C++ compiler (the install compiles the plugin with one)")
    info = subprocess.run([sys.executable, str(ROOT / "plugins" / "lammps_build_info.py")],
                          capture_output=True, text=True, timeout=120, check=True).stdout
    keys = dict(ln.split("=", 1) for ln in info.splitlines() if "=" in ln)
    flags = ["-std=c++17", "-fsyntax-only", "-Wall", "-Wextra", "-Werror",
             "-DLAMMPS_SMALLBIG", '-DBK_LAMMPS_VERSION="x"', '-DBK_LAMMPS_GIT="x"',
             "-DBK_FUSED_AVX2", "-DBK_FUSED_AVX512",
             f"-I{keys['LAMMPS_INCLUDE_DIR']}", f"-I{keys['MPI_INCLUDE_DIR']}"]
    sources = sorted((ROOT / "plugins").glob("*.cpp"))
    procs = [subprocess.Popen([cxx, *flags, str(s)], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True) for s in sources]
    failed = {}
    for src, p in zip(sources, procs):
        out, _ = p.communicate(timeout=600)
        if p.returncode != 0:
            failed[src.name] = out[-2000:]
    assert not failed, failed


def test_the_tests_mirror_the_package():
    """tests/<group>/ for each group of src/bkflow (and the plugin, the paper's workflow, the
    benchmarks' checks);
    at the top only what spans the house: its layers, the recipes of docs/develop.md, the
    README and the generated blocks."""
    tests = ROOT / "tests"
    dirs = {d.name for d in tests.iterdir() if d.is_dir() and d.name != "__pycache__"}
    assert dirs - {"plugins", "workflows", "benchmarks"} <= set(GROUPS), dirs
    top = {p.name for p in tests.glob("test_*.py")}
    assert top <= {"test_house.py", "test_house_imports.py", "test_extending.py",
                   "test_readme.py", "test_results_blocks.py"}, top
