"""bkflow.store.provenance, tested directly: the provenance block of meta.json (its keys, the
Python that ran), the versions of the installed distributions (as importlib.metadata gives
them), and the source bkflow runs from: a git checkout's commit and whether its tracked files
changed, None for both outside one (a copy of the module in a git work tree or none)."""

from __future__ import annotations

import importlib.metadata as md
import importlib.util
import platform
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from bkflow.store import provenance


def _normal(name: str) -> str:
    """A distribution's name as PEP 503 normalises it."""
    return re.sub(r"[-_.]+", "-", name).lower()


def test_the_record_holds_the_source_python_and_libraries():
    rec = provenance.record()
    assert list(rec) == ["git_commit", "git_dirty", "python", "implementation", "libraries"]
    assert rec["python"] == platform.python_version()
    assert rec["implementation"] == platform.python_implementation()
    assert list(rec["libraries"]) == list(provenance.LIBRARIES)
    assert {k: rec[k] for k in ("git_commit", "git_dirty")} == provenance.source()


def test_the_installed_versions_are_those_importlib_metadata_gives():
    found = provenance.installed_versions()
    assert found["numpy"] == md.version("numpy") and found["pandas"] == md.version("pandas")
    for name, version in found.items():                 # each a real distribution
        assert md.version(name) == version, name
    # and every distribution of a .dist-info directory on the path is there, the first found
    # of each name (the one Python imports)
    first = {}
    for dist in md.distributions():
        if dist.read_text("METADATA") is not None:
            first.setdefault(_normal(dist.metadata["Name"]), dist.version)
    assert found == first


def test_the_first_distribution_of_a_name_on_the_path_is_the_one_named(tmp_path, monkeypatch):
    first, second = tmp_path / "first", tmp_path / "second"
    for where, names in ((first, ["Foo_Bar.baz-1.0.dist-info", "notes-1.0.txt"]),
                         (second, ["foo_bar_baz-2.0.dist-info", "other-3.1rc1.dist-info"])):
        for name in names:
            (where / name).mkdir(parents=True)
    (tmp_path / "a.zip").write_bytes(b"")              # a path entry that is no directory
    monkeypatch.setattr(sys, "path", [str(tmp_path / "a.zip"), str(tmp_path / "none"),
                                      str(first), str(second)])
    assert provenance.installed_versions() == {"foo-bar-baz": "1.0", "other": "3.1rc1"}


def test_a_dist_info_directory_without_a_version_is_passed_over(tmp_path, monkeypatch):
    (tmp_path / "broken.dist-info").mkdir()
    (tmp_path / "fine-1.0.dist-info").mkdir()
    monkeypatch.setattr(sys, "path", [str(tmp_path)])
    assert provenance.installed_versions() == {"fine": "1.0"}


def test_the_libraries_are_named_with_their_versions_or_none():
    libs = provenance.libraries()
    assert list(libs) == list(provenance.LIBRARIES)
    for name, version in libs.items():
        try:
            assert version == md.version(name), name
        except md.PackageNotFoundError:
            assert version is None, name
    assert libs["numpy"] == md.version("numpy")


def _git(*args, cwd):
    return subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@example.org",
                           "-c", "commit.gpgsign=false", *args],
                          cwd=cwd, capture_output=True, text=True, check=True).stdout.strip()


def _module_at(where: Path):
    """A copy of bkflow.store.provenance living in ``where``: its source() looks at the git
    work tree around ``where``."""
    where.mkdir(parents=True, exist_ok=True)
    copy = where / "provenance.py"
    shutil.copyfile(provenance.__file__, copy)
    spec = importlib.util.spec_from_file_location("provenance_copy", copy)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def no_git_above(tmp_path, monkeypatch):
    """git looks for a work tree no higher than tmp_path."""
    if shutil.which("git") is None:
        pytest.fail("git is not installed")
    monkeypatch.setenv("GIT_CEILING_DIRECTORIES", str(tmp_path))
    return tmp_path


def test_the_source_is_a_checkouts_commit_and_whether_it_changed(no_git_above):
    repo = no_git_above / "checkout"
    repo.mkdir()
    _git("init", "-q", cwd=repo)
    (repo / "pyproject.toml").write_text("[project]\nname = 'x'\n")
    module_dir = repo / "src" / "pkg"
    _module_at(module_dir)
    _git("add", "-A", cwd=repo)
    _git("commit", "-q", "-m", "one", cwd=repo)
    head = _git("rev-parse", "HEAD", cwd=repo)
    assert re.fullmatch("[0-9a-f]{40}", head)
    assert _module_at(module_dir).source() == {"git_commit": head, "git_dirty": False}
    (repo / "untracked.txt").write_text("x")            # untracked: not a change of the source
    assert _module_at(module_dir).source() == {"git_commit": head, "git_dirty": False}
    (repo / "pyproject.toml").write_text("[project]\nname = 'y'\n")
    assert _module_at(module_dir).source() == {"git_commit": head, "git_dirty": True}


def test_no_source_is_claimed_outside_a_checkout_of_bkflow(no_git_above):
    nothing = {"git_commit": None, "git_dirty": None}
    assert _module_at(no_git_above / "site-packages" / "pkg").source() == nothing
    # a git work tree that is not a project's (no pyproject.toml at its top): not bkflow's
    repo = no_git_above / "other"
    repo.mkdir()
    _git("init", "-q", cwd=repo)
    (repo / "README").write_text("x")
    _git("add", "-A", cwd=repo)
    _git("commit", "-q", "-m", "one", cwd=repo)
    assert _module_at(repo / "lib").source() == nothing


def test_this_bkflows_source_is_the_checkout_it_runs_from():
    here = Path(provenance.__file__).resolve().parent
    top = subprocess.run(["git", "rev-parse", "--show-toplevel"], cwd=here,
                         capture_output=True, text=True)
    if top.returncode != 0 or not (Path(top.stdout.strip()) / "pyproject.toml").is_file():
        pytest.skip("bkflow runs from an installed copy, not from a checkout")
    provenance.source.cache_clear()
    src = provenance.source()
    assert src["git_commit"] == subprocess.run(["git", "rev-parse", "HEAD"], cwd=here,
                                               capture_output=True, text=True).stdout.strip()
    assert isinstance(src["git_dirty"], bool)
