"""Adding to the model and to the analysis: the diffs of docs/develop.md add a contact rule in at
most four places outside the tests and docs, and the scratch copy it makes passes its own
reference tests on the new rule, on both integration paths; and an observable in at most four,
which the scratch copy then reports in the summary, the tables, the command line and a figure."""

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


def test_a_new_contact_rule_touches_at_most_four_places():
    hunks = _hunks_by_file(_rule_diff())
    outside = {f: n for f, n in hunks.items() if not f.startswith(("tests/", "docs/"))}
    assert set(outside) == {"plugins/bk_model.h", "src/bkflow/model/params.py"}
    assert sum(outside.values()) <= MAX_PLACES and len(outside) <= MAX_FILES, outside
    assert "tests/reference.py" in hunks  # the independent check learns the rule too


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
    """The documented diff, applied to a scratch copy (git apply --check first: the diff is
    current), built and tested by the copy's own tests, selected by the new rule's name."""
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
         "tests/model/test_start.py"],
        cwd=scratch, env=env, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    ran = re.search(r"(\d+) passed", proc.stdout)
    assert ran and int(ran.group(1)) >= 10, proc.stdout[-2000:]


def test_a_new_observable_touches_at_most_four_places():
    hunks = _hunks_by_file(_diff("Adding an observable"))
    outside = {f: n for f, n in hunks.items() if not f.startswith(("tests/", "docs/"))}
    assert "src/bkflow/analysis/registry.py" in outside
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
            "import bkflow.analysis.registry as r; "
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
