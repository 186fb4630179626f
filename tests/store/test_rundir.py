"""bkflow.store's run directory, tested directly: its files (``RunFiles``), its completion
record and the checks on it (rundir), the analysis's files (analysed), the lock and the claim
(lock)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bkflow.model.params import RunSpec
from bkflow.model.settings import AnalysisSettings
from bkflow.store.layout import DECK, MARK, META, PARAMS, STRESS, SUMMARY, RunFiles
from bkflow.store.rundir import RunDir


def _fake_run(d: Path) -> RunDir:
    rd = RunDir(d)
    d.mkdir(parents=True, exist_ok=True)
    rd.file(STRESS).write_text("t,sigma_x\n0,0\n0.1,0.01\n")
    rd.commit({"params": RunSpec(phi=1.0).to_dict()})
    return rd


def test_a_run_directory_knows_when_its_files_were_cut(tmp_path):
    rd = _fake_run(tmp_path / "r")
    assert rd.problem() is None and rd.is_complete()
    meta = json.loads(rd.file(META).read_text())
    assert meta["file_bytes"] == {STRESS: rd.file(STRESS).stat().st_size}
    with open(rd.file(STRESS), "r+b") as f:
        f.truncate(10)
    assert "stress.csv has 10 bytes" in rd.problem()
    rd.file(STRESS).unlink()
    assert rd.problem() == "stress.csv is missing"
    assert RunDir(tmp_path / "none").problem() == "not run (no meta.json)"


def test_a_summary_is_stale_under_other_settings(tmp_path):
    rd = _fake_run(tmp_path / "r")
    assert rd.analysis_problem() == "no summary.json"
    settings = AnalysisSettings()
    spec = rd.spec()
    rd.write_analysis({"mu_bar": 0.1, "params": spec.to_dict(),
                       "settings": settings.resolved(spec).to_dict()}, {})
    assert rd.analysis_problem(settings) is None
    assert "other analysis settings (s_x)" in rd.analysis_problem(AnalysisSettings(s_x=0.5))
    rd.file(SUMMARY).write_text('{"mu_bar": 0.1')
    assert rd.analysis_problem(settings) == "summary.json unreadable"


def test_a_second_writer_is_refused_while_the_first_holds_the_lock(tmp_path):
    import fcntl
    import os

    from bkflow.store.errors import RunBusyError
    from bkflow.store.layout import LOCK

    rd = RunDir(tmp_path)
    fd = os.open(tmp_path / LOCK, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as another process would
    try:
        with pytest.raises(RunBusyError, match="another bkflow process"):
            with rd.lock():
                pass
    finally:
        os.close(fd)
    with rd.lock(), rd.lock():  # re-entrant within a process
        pass


def test_a_directory_is_bkflows_to_write_into_only_when_empty_or_its_own(tmp_path):
    """``RunDir.foreign``: what makes a directory not bkflow's to write a run into."""
    assert RunDir(tmp_path / "none").foreign() is None            # made when run
    (tmp_path / "empty").mkdir()
    assert RunDir(tmp_path / "empty").foreign() is None
    assert RunDir(_fake_run(tmp_path / "run").path).foreign() is None
    (tmp_path / "a file").write_text("x")
    assert RunDir(tmp_path / "a file").foreign() == "is a file, not a directory"
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "notes.txt").write_text("x")
    assert "holds files that are not a bkflow run (notes.txt)" in RunDir(theirs).foreign()
    deck = tmp_path / "deck"
    deck.mkdir()
    for name in (DECK, PARAMS):
        (deck / name).write_text("x")
    assert "holds a deck written by bkflow deck" in RunDir(deck).foreign()
    claimed = tmp_path / "claimed"
    RunDir(claimed).path.mkdir()
    RunDir(claimed).mark()                                     # a run under way: its own
    assert (claimed / MARK).exists() and RunDir(claimed).foreign() is None


def test_every_part_of_a_run_directory_stands_on_its_files():
    """The lock, the readers and the analysis's files are parts of RunDir on one base that
    holds the path (RunFiles), not mixins that assume it."""
    from bkflow.store.analysed import RunAnalysisFiles
    from bkflow.store.lock import RunLock
    from bkflow.store.readers import RunReaders

    for part in (RunLock, RunReaders, RunAnalysisFiles, RunDir):
        assert issubclass(part, RunFiles)
    d = RunDir("runs/phi10")
    assert repr(d) == "RunDir('runs/phi10')" and d.file(STRESS) == Path("runs/phi10") / STRESS
