"""bkflow.store.analysed, tested directly: the analysis written as its tables then summary.json
(the record of them), the checks that say why an analysis is stale or its tables are not the
ones it wrote, the settings a run is analysed under again, and the tables read back only
when they are the analysis's own."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from bkflow.model.params import RunSpec
from bkflow.model.settings import ANALYSIS_REVISION, AnalysisSettings
from bkflow.store.errors import DamagedRunError
from bkflow.store.files import file_record, shell_word
from bkflow.store.layout import EVENTS, EVENTS_PARQUET, PSI, PSI_RECORD, STRESS, SUMMARY
from bkflow.store.rundir import RunDir

SPEC = RunSpec(phi=1.0)
EVENTS_TABLE = pd.DataFrame({"t_max": [1.0, 2.5], "t_min": [1.2, 2.75],
                             "sigma_fail": [0.5, 0.6], "drop": [0.1, 0.2], "late": [0.0, 1.0]})
PSI_TABLE = pd.DataFrame({"t": [0.0, 20.0], "psi": [0.1, 0.3]})


def _analysed(d, settings: AnalysisSettings | None = None) -> RunDir:
    """A finished run (its stress as a run before 0.5 kept it) and its analysis."""
    rd = RunDir(d)
    d.mkdir(parents=True, exist_ok=True)
    rd.file(STRESS).write_text("t,sigma_x\n0,0\n0.1,0.01\n")
    rd.commit({"params": SPEC.to_dict()})
    rd.write_analysis({"mu_bar": 0.1, "params": SPEC.to_dict(), "t_transient": 0.0,
                       "settings": (settings or AnalysisSettings()).resolved(SPEC).to_dict()},
                      {EVENTS: EVENTS_TABLE, PSI: PSI_TABLE})
    return rd


def test_the_tables_are_written_before_the_summary_that_records_them(tmp_path):
    rd = RunDir(tmp_path)
    tmp_path.mkdir(exist_ok=True)
    rd.file(EVENTS).write_text("t_max\n1\n")                   # a run analysed before 0.5
    rd = _analysed(tmp_path)
    s = json.loads(rd.file(SUMMARY).read_text())
    assert s["tables"] == [EVENTS_PARQUET, PSI]                 # events stored as Parquet only
    assert s["analysis_revision"] == ANALYSIS_REVISION
    assert s["table_files"] == {n: file_record(rd.file(n)) for n in (EVENTS_PARQUET, PSI)}
    assert not rd.file(EVENTS).exists()
    assert rd.summary() == s and rd.analysis_problem() is None and rd.table_problem() is None
    events = rd.read_events()
    np.testing.assert_array_equal(events.t_max, EVENTS_TABLE.t_max)
    assert str(events.late.dtype) == "boolean" and list(events.late) == [False, True]
    pd.testing.assert_frame_equal(rd.read_psi_table(), PSI_TABLE, check_exact=True)
    assert rd.has_events()


def _cut(p):
    p.write_bytes(p.read_bytes()[:-3])


def _written_over(p):
    p.write_text(p.read_text().replace("0.3", "0.4"))                # the same size


def _linked(p):
    copy = p.with_name("copy.csv")
    copy.write_bytes(p.read_bytes())
    p.unlink()
    p.symlink_to(copy)


@pytest.mark.parametrize("damage, why", [
    (_cut, "psi.csv is not the table the analysis wrote (cut, emptied or replaced)"),
    (_written_over, "psi.csv is not the table the analysis wrote (cut, emptied or replaced)"),
    (lambda p: p.unlink(), "psi.csv is missing"),
    (_linked, "psi.csv is missing"),
], ids=["cut", "written over", "missing", "a link to a copy"])
def test_a_table_that_is_not_the_analysiss_own_is_refused(tmp_path, damage, why):
    d = tmp_path / "my run"
    rd = _analysed(d)
    damage(rd.file(PSI))
    assert rd.table_problem() == why and rd.analysis_problem() == why
    repair = (f"{d}: {why}; bkflow analyze {shell_word(d)} (or bkflow collect, for a sweep) "
              "makes the analysis again")
    # the tables are one set with their summary: a reader of one checks them all
    for read in (rd.read_psi_table, rd.read_events):
        with pytest.raises(DamagedRunError) as exc:
            read()
        assert str(exc.value) == repair


def test_a_table_the_summary_lists_that_is_gone_is_damage_not_absence(tmp_path):
    rd = _analysed(tmp_path)
    rd.file(PSI).unlink()
    assert rd.table_problem() == "psi.csv is missing"
    with pytest.raises(DamagedRunError, match="psi.csv is missing"):
        rd.read_psi_table()


def test_why_an_analysis_is_stale(tmp_path):
    rd = _analysed(tmp_path)
    s = rd.summary()
    assert rd.analysis_problem(AnalysisSettings(s_x=0.5)) == \
        "summary.json made under other analysis settings (s_x)"
    assert rd.analysis_problem(spec=RunSpec(phi=2.0)) == "summary.json belongs to other parameters"
    rd.file(SUMMARY).write_text(json.dumps({**s, "analysis_revision": ANALYSIS_REVISION - 1}))
    assert rd.analysis_problem() == (f"summary.json made by analysis revision "
                                     f"{ANALYSIS_REVISION - 1}, this bkflow's is "
                                     f"{ANALYSIS_REVISION}")
    rd.file(SUMMARY).write_text(json.dumps({"mu_bar": 0.1}))
    assert rd.analysis_problem() == "summary.json is not a bkflow summary"
    rd.file(SUMMARY).write_text(json.dumps({k: v for k, v in s.items() if k != "table_files"}))
    assert rd.analysis_problem() == "summary.json does not record its tables"
    rd.file(SUMMARY).write_text("[]")
    assert rd.summary() is None and rd.analysis_problem() == "summary.json unreadable"
    rd.file(SUMMARY).unlink()
    assert rd.analysis_problem() == "no summary.json" and rd.table_problem() == "no summary.json"


def test_a_run_is_analysed_again_under_its_last_analysiss_settings(tmp_path):
    rd = _analysed(tmp_path, AnalysisSettings(s_x=0.05))
    assert rd.kept_settings().s_x == 0.05
    s = rd.summary()
    rd.file(SUMMARY).write_text(json.dumps({**s, "analysis_revision": ANALYSIS_REVISION - 1}))
    assert rd.kept_settings() == AnalysisSettings()           # another revision's: defaults
    rd.file(SUMMARY).write_text(json.dumps({**s, "settings": {"no such setting": 1}}))
    assert rd.kept_settings() == AnalysisSettings()


def test_only_the_analysis_is_left_of_a_finished_run_whose_analysis_is_stale(tmp_path):
    rd = _analysed(tmp_path)
    meta = rd.meta()
    rd.file("meta.json").write_text(json.dumps({**meta, "requested": SPEC.to_dict()}))
    assert not rd.only_analysis_left(SPEC)                       # current: nothing left
    assert rd.only_analysis_left(SPEC, AnalysisSettings(s_x=0.5))
    assert not rd.only_analysis_left(RunSpec(phi=2.0), AnalysisSettings(s_x=0.5))


def test_the_events_are_there_when_written_or_listed(tmp_path):
    rd = _analysed(tmp_path)
    rd.file(EVENTS_PARQUET).unlink()
    assert rd.has_events()                     # listed by the summary: missing is damage
    with pytest.raises(DamagedRunError, match="events.parquet is missing"):
        rd.read_events()
    rd.file(SUMMARY).unlink()
    assert not rd.has_events()


def test_psi_of_the_run_comes_before_the_analysiss_table(tmp_path):
    rd = _analysed(tmp_path)
    psi = np.zeros(2, [("step", "<i8"), ("psi", "<f8")])
    psi["step"], psi["psi"] = [0, 700], [0.25, 0.75]
    np.save(rd.file(PSI_RECORD), psi)
    got = rd.read_psi_table()
    np.testing.assert_array_equal(got.t, np.array([0, 700]) * SPEC.dt)
    np.testing.assert_array_equal(got.psi, [0.25, 0.75])
    rd.file(PSI_RECORD).unlink()
    rd.file(PSI).unlink()
    rd.write_analysis({**rd.summary()}, {})                   # an analysis without Psi
    assert rd.read_psi_table() is None and rd.read_clusters() is None
