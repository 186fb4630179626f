"""Adding to the model and to the analysis: the diffs of docs/develop.md, each hunk at exactly
the lines it states, add a contact rule in at most four places outside the tests and docs, and
the scratch copy it makes passes its own reference and ledger tests on the new rule, on both
integration paths; and an observable in at most four, which the scratch copy then reports in
the summary, the tables, the command line and a figure."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys

import pytest

from tests.support import ROOT

#: the places (diff hunks) and files a new contact rule may touch outside tests/ and docs/
MAX_PLACES, MAX_FILES = 4, 2


def _diff(section: str) -> str:
    """The one diff under docs/develop.md's heading ``section``."""
    text = (ROOT / "docs" / "develop.md").read_text()
    part = text.split(f"## {section}\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```diff\n(.*?)```", part, flags=re.S)
    assert len(blocks) == 1, f"docs/develop.md's {section!r} holds one diff"
    return blocks[0]


def _rule_diff() -> str:
    return _diff("Adding a contact rule")


def _hunks_by_file(diff: str) -> dict[str, int]:
    files: dict[str, int] = {}
    name = None
    for line in diff.splitlines():
        if line.startswith("+++ b/"):
            name = line[len("+++ b/"):]
            files[name] = 0
        elif line.startswith("@@") and name is not None:
            files[name] += 1
    return files


def _outside_tests_and_docs(hunks: dict[str, int]) -> dict[str, int]:
    """The files of ``hunks`` that are neither tests nor documentation (docs/, any .md)."""
    return {f: n for f, n in hunks.items()
            if not f.startswith(("tests/", "docs/")) and not f.endswith(".md")}


def test_a_new_contact_rule_touches_at_most_four_places():
    hunks = _hunks_by_file(_rule_diff())
    outside = _outside_tests_and_docs(hunks)
    assert set(outside) == {"plugins/bk_model.h", "src/bkflow/model/params.py"}
    assert sum(outside.values()) <= MAX_PLACES and len(outside) <= MAX_FILES, outside
    assert "tests/reference.py" in hunks  # the independent check learns the rule too
    assert "plugins/README.md" in hunks   # and the fix's documented syntax


#: the sections of docs/develop.md that hold a recipe's diff
RECIPES = [part.split("\n", 1)[0] for part in
           (ROOT / "docs" / "develop.md").read_text().split("\n## ")[1:] if "```diff\n" in part]
HUNK = re.compile(r"@@ -(\d+)(?:,(\d+))? \+(\d+)(?:,(\d+))? @@")


def _misplaced_hunks(diff: str) -> list[str]:
    """The hunks of ``diff`` that do not apply to the repository's files exactly where their
    headers say: the old lines not at the stated line (git apply and patch would look
    elsewhere, at an offset or with fuzz), a count that is not the hunk's, or a new-file start
    that does not follow from the hunks above it."""
    bad: list[str] = []
    lines = diff.splitlines()
    name, text, shift = "", [], 0
    for k, line in enumerate(lines):
        if line.startswith("+++ b/"):
            name, shift = line[len("+++ b/"):], 0
            text = (ROOT / name).read_text().splitlines() if (ROOT / name).is_file() else []
        m = HUNK.match(line)
        if not m:
            continue
        body = []
        for ln in lines[k + 1:]:
            if ln.startswith(("@@", "diff ", "--- a/", "--- /dev/null", "+++ b/")):
                break
            if not ln.startswith("\\"):          # "\ No newline at end of file"
                body.append(ln or " ")            # an empty context line, its space trimmed
        old = [ln[1:] for ln in body if ln[0] in " -"]
        new = [ln[1:] for ln in body if ln[0] in " +"]
        a, c = int(m[1]), int(m[3])
        b, d = int(m[2] or 1), int(m[4] or 1)
        where = f"{name} {m[0]}"
        if (b, d) != (len(old), len(new)):
            bad.append(f"{where}: the hunk has {len(old)} old and {len(new)} new lines")
        elif old and text[a - 1:a - 1 + b] != old:
            found = [i + 1 for i in range(len(text)) if text[i:i + b] == old]
            bad.append(f"{where}: its lines are at {found or 'no line'} of {name}")
        elif old and new and c != a + shift:
            bad.append(f"{where}: the new file's hunk starts at {a + shift}")
        shift += d - b
    return bad


@pytest.mark.parametrize("section", RECIPES)
def test_every_hunk_of_a_recipe_applies_at_exactly_its_lines(section):
    """git apply and patch take a hunk found a few lines off (an offset), so a diff of
    docs/develop.md can go stale and still apply: each hunk must match its file at exactly
    the lines its header states."""
    bad = _misplaced_hunks(_diff(section))
    assert not bad, f"docs/develop.md's diff is stale (rewrite it with git diff): {bad}"


def test_every_recipe_is_checked_line_by_line():
    assert {"Adding a contact rule", "Adding an observable"} <= set(RECIPES), RECIPES


def _scratch_package(tmp_path, diff: str, *more: str):
    """The tracked package and tests (and the folders ``more``) copied to ``tmp_path/repo``,
    with ``diff`` applied (git apply --check first: the diff is current)."""
    scratch = tmp_path / "repo"
    files = subprocess.run(["git", "ls-files", *more, "src", "tests", "pyproject.toml"],
                           cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    if not files:
        pytest.fail("not a git checkout: the scratch copy takes the tracked files")
    for f in files:
        (scratch / f).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / f, scratch / f)
    patch = tmp_path / "change.diff"
    patch.write_text(diff)
    for check in (["--check"], []):
        proc = subprocess.run(["git", "apply", *check, str(patch)], cwd=scratch,
                              capture_output=True, text=True)
        assert proc.returncode == 0, "docs/develop.md's diff no longer applies: " + proc.stderr
    return scratch


@pytest.mark.slow
def test_a_throwaway_contact_rule_passes_the_reference_tests_on_both_paths(lammps, tmp_path):
    """The documented diff, applied to a scratch copy (git apply --check first: the diff
    applies), built and tested by the copy's own tests (the reference on both paths, the
    energy ledger, the starts), selected by the new rule's name."""
    scratch = _scratch_package(tmp_path, _rule_diff(), "plugins")
    build = tmp_path / "build"
    for cmd in (["cmake", "-S", str(scratch / "plugins"), "-B", str(build), "-G", "Ninja",
                 "-DCMAKE_BUILD_TYPE=Release", f"-DPython_EXECUTABLE={sys.executable}"],
                ["cmake", "--build", str(build)]):
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    # the scratch package first: the editable install's finder steps aside
    boot = ("import sys; sys.meta_path[:] = [f for f in sys.meta_path "
            "if not type(f).__module__.startswith('_editable_')]; "
            f"sys.path.insert(0, {str(scratch / 'src')!r}); sys.path.insert(0, {str(scratch)!r});"
            " import bkflow.model.params as p; assert 'halve' in p.CONTACT_RULES, p.__file__; "
            "import pytest; sys.exit(pytest.main(sys.argv[1:]))")
    env = {**os.environ, "BKFLOW_PLUGIN_DIR": str(build)}
    proc = subprocess.run(
        [sys.executable, "-c", boot, "-q", "-p", "no:cacheprovider", "-k", "halve",
         "tests/plugins/test_reference.py", "tests/plugins/test_fused.py",
         "tests/plugins/test_ledger.py", "tests/model/test_start.py"],
        cwd=scratch, env=env, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    ran = re.search(r"(\d+) passed", proc.stdout)
    assert ran and int(ran.group(1)) >= 10, proc.stdout[-2000:]


def test_a_new_observable_touches_at_most_four_places():
    hunks = _hunks_by_file(_diff("Adding an observable"))
    outside = _outside_tests_and_docs(hunks)
    assert "src/bkflow/analysis/summary_keys.py" in outside
    assert sum(outside.values()) <= MAX_PLACES and len(outside) <= MAX_FILES, outside


@pytest.mark.slow
def test_a_throwaway_observable_reaches_the_summary_tables_cli_and_a_figure(lammps, tmp_path):
    """The documented diff, applied to a scratch copy; a run and a two-point sweep with the
    scratch package find ``mean_drop`` everywhere a result shows."""
    import json

    import pandas as pd

    scratch = _scratch_package(tmp_path, _diff("Adding an observable"))
    boot = ("import sys; sys.meta_path[:] = [f for f in sys.meta_path "
            "if not type(f).__module__.startswith('_editable_')]; "
            f"sys.path.insert(0, {str(scratch / 'src')!r}); "
            "import bkflow.analysis.summary_keys as r; "
            "assert 'mean_drop' in {o.name for o in r.OBSERVABLES}, r.__file__; "
            "from bkflow.cli import main; sys.exit(main(sys.argv[1:]))")

    def bk(*args):
        proc = subprocess.run([sys.executable, "-c", boot, *args], cwd=tmp_path,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
        return proc.stdout

    out = bk("run", "--phi", "10", "--protocol", "paper", "--t-end", "400", "--out", "one")
    assert "mean stress drop = " in out, out
    summary = json.loads((tmp_path / "one" / "summary.json").read_text())
    assert summary["mean_drop"] > 0
    bk("sweep", "--phi", "1,100", "--seeds", "2", "--protocol", "paper", "--t-end", "400",
       "--out", "grid", "--quiet")
    runs = pd.read_csv(tmp_path / "grid" / "runs.csv")
    results = pd.read_csv(tmp_path / "grid" / "results.csv")
    assert (runs["mean_drop"] > 0).all() and len(runs) == 4
    assert {"mean_drop", "mean_drop_sem"} <= set(results.columns)
    bk("plot", "grid")
    drawn = json.loads((tmp_path / "grid" / "figures" / "figures.json").read_text())["files"]
    assert any(f.startswith("fig_mean_drop") for f in drawn), drawn
