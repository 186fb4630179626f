"""bkflow.store.tables, tested directly: a sweep's runs.csv and results.csv written as one set
and read back, every way the set is found broken (stale, cut, replaced, missing, a record
that names a path outside), the settings and the parameters of the tables, the rows of some
specs' points, the catalogue of the runs' events, and the figures drawn from the tables:
recorded, and retired once the tables change (never a file that is not theirs)."""

from __future__ import annotations

import json
import os

import numpy as np
import pandas as pd
import pytest

from bkflow.model.params import RunSpec
from bkflow.store import tables
from bkflow.store.errors import DamagedRunError
from bkflow.store.files import file_record, shell_word


def _runs() -> pd.DataFrame:
    return pd.DataFrame({"job": ["a1", "b2", "c3"], "phi": [1.0, 1.0, 2.0],
                         "Lx": [20, 20, 20], "Ly": [5, 5, 5], "seed": [1, 2, 1],
                         "dt_factor": [np.nan, np.nan, 0.5], "mu_bar": [0.1, 0.1 + 0.2, 1 / 3]})


def _results() -> pd.DataFrame:
    return pd.DataFrame({"phi": [1.0, 2.0], "Lx": [20, 20], "Ly": [5, 5],
                         "dt_factor": [np.nan, 0.5], "mu_bar": [0.2, 1 / 3], "n_runs": [2, 1]})


@pytest.fixture
def sweep(tmp_path):
    """A sweep directory (its name one a shell splits) with its tables written as a set."""
    root = tmp_path / "my sweep"
    root.mkdir()
    tables.write_table_set(root, _runs(), _results(), {"s_x": 0.01, "transient": None})
    return root


def test_the_tables_are_written_as_one_set_and_read_back(tmp_path):
    root = tmp_path
    for old in (tables.CATALOGUE_FILE, tables.CATALOGUE_PARQUET):   # an earlier bkflow's
        (root / old).write_text("x")
    tables.write_table_set(root, _runs(), _results(), {"s_x": 0.01})
    record = json.loads((root / tables.SETTINGS_FILE).read_text())
    assert tables.settings_in(record) == {"s_x": 0.01}
    assert record[tables.TABLES_KEY] == {name: file_record(root / name)
                                         for name in (tables.RUNS_FILE, tables.RESULTS_FILE)}
    assert not (root / tables.CATALOGUE_FILE).exists()
    assert not (root / tables.CATALOGUE_PARQUET).exists()
    assert tables.tables_problem(root) is None
    tables.check_tables(root)
    runs, results = tables.read_tables(root)
    pd.testing.assert_frame_equal(runs, _runs(), check_exact=True)
    pd.testing.assert_frame_equal(results, _results(), check_exact=True)


def test_tables_that_are_absent_or_empty_are_refused_as_promised(tmp_path):
    with pytest.raises(FileNotFoundError) as absent:
        tables.read_tables(tmp_path)
    assert absent.value.filename == str(tmp_path / tables.RUNS_FILE)
    tables.write_table_set(tmp_path, pd.DataFrame(), pd.DataFrame(), {})
    assert tables.tables_problem(tmp_path) is None             # the set is whole ...
    with pytest.raises(pd.errors.EmptyDataError):                # ... and holds nothing
        tables.read_tables(tmp_path)


def _damage(root, how: str) -> None:
    runs, results = root / tables.RUNS_FILE, root / tables.RESULTS_FILE
    settings = root / tables.SETTINGS_FILE
    if how == "no record":
        settings.unlink()
    elif how == "an older bkflow's record":
        settings.write_text('{"s_x": 0.01}\n')
    elif how == "a cut record":
        settings.write_text(settings.read_text()[:40])
    elif how == "a table cut":
        runs.write_bytes(runs.read_bytes()[:30])
    elif how == "a table written apart, its size kept":
        results.write_text(results.read_text().replace("0.2,", "0.3,", 1))
    elif how == "a table missing":
        results.unlink()
    elif how == "a table replaced by a link to its copy":
        os.replace(results, root / "copy.csv")
        results.symlink_to(root / "copy.csv")
    elif how == "a record naming a file outside":
        record = json.loads(settings.read_text())
        record[tables.TABLES_KEY]["../victim.csv"] = {"bytes": 1, "sha256": "0"}
        settings.write_text(json.dumps(record))
    elif how == "an old catalogue beside":
        (root / tables.CATALOGUE_PARQUET).write_bytes(b"PAR1")


@pytest.mark.parametrize("how, why", [
    ("no record", "analysis.json does not record the tables it belongs with"),
    ("an older bkflow's record", "analysis.json does not record the tables it belongs with"),
    ("a cut record", "analysis.json does not record the tables it belongs with"),
    ("a table cut", "runs.csv is not the one the last collect wrote (cut, or written apart)"),
    ("a table written apart, its size kept",
     "results.csv is not the one the last collect wrote (cut, or written apart)"),
    ("a table missing", "results.csv is missing"),
    ("a table replaced by a link to its copy", "results.csv is missing"),
    ("a record naming a file outside",
     "analysis.json names '../victim.csv', which is not a table of the sweep's"),
    ("an old catalogue beside", "catalogue.parquet is not one the last collect wrote"),
])
def test_a_broken_set_of_tables_is_named_and_refused(sweep, how, why):
    _damage(sweep, how)
    assert tables.tables_problem(sweep) == why
    message = f"{sweep}: {why}; bkflow collect {shell_word(sweep)} writes the sweep's tables"
    with pytest.raises(tables.StaleTablesError) as stale:
        tables.check_tables(sweep)
    assert str(stale.value) == message + " again"
    assert isinstance(stale.value, DamagedRunError)      # the command line's exit code for it
    with pytest.raises(tables.StaleTablesError):
        tables.read_tables(sweep)


def test_a_table_replaced_by_a_link_is_refused(sweep):
    _damage(sweep, "a table replaced by a link to its copy")
    assert "results.csv" in tables.tables_problem(sweep)
    with pytest.raises(tables.StaleTablesError, match="results.csv"):
        tables.read_tables(sweep)


def test_the_settings_of_a_record_leave_the_tables_out():
    record = {"s_x": 0.01, "transient": None, tables.TABLES_KEY: {"runs.csv": {}}}
    assert tables.settings_in(record) == {"s_x": 0.01, "transient": None}
    assert tables.settings_in({}) == {}


def test_the_varied_parameters_are_those_besides_phi_size_and_seed_of_several_values():
    results = pd.DataFrame({
        "phi": [1.0, 2.0, 3.0], "Lx": [20, 40, 20], "Ly": [5, 10, 5], "seed": [1, 2, 3],
        "gamma": [0.2, 0.1, 0.2], "dt_factor": [np.nan, 0.5, np.nan], "k_e": [10.0] * 3,
        "target_error": [np.nan] * 3, "contact_rule": ["reset", "reset", "keep"],
        "mu_bar": [0.1, 0.2, 0.3]})                          # an observable: no parameter
    # in RunSpec's order of its fields
    assert tables.varied_parameters(results) == ["dt_factor", "contact_rule", "gamma"]
    assert tables.varied_parameters(results.iloc[:1]) == []
    assert tables.varied_parameters(pd.DataFrame({"mu_bar": [1.0, 2.0]})) == []


def test_the_rows_of_some_specs_are_their_points_whatever_the_seed():
    results = pd.DataFrame({"phi": [1.0, 1.0, 2.0, 2.0], "Lx": [20.0, 40.0, 20.0, 20.0],
                            "Ly": [5, 10, 5, 5], "dt_factor": [np.nan, np.nan, np.nan, 0.5],
                            "seed": [1, 1, 1, 1], "mu_bar": [0.1, 0.2, 0.3, 0.4]})
    rows = tables.rows_of(results, [RunSpec(phi=1.0, seed=9),            # the seed: any
                                    RunSpec(phi=2.0, dt_factor=0.5)])
    assert list(rows.index) == [0, 3] and list(rows.mu_bar) == [0.1, 0.4]
    # None and NaN alike, 20 and 20.0 alike; k_e, not in the table, not compared
    assert list(tables.rows_of(results, [RunSpec(phi=2.0, k_e=3.0)]).index) == [2]
    assert tables.rows_of(results, [RunSpec(phi=3.0)]).empty
    assert tables.rows_of(results, []).empty
    with_k_e = results.assign(k_e=[10.0, 10.0, 3.0, 10.0])
    assert list(tables.rows_of(with_k_e, [RunSpec(phi=2.0)]).index) == []


def test_the_digest_of_the_tables_changes_when_a_table_changes(sweep):
    first = tables.tables_digest(sweep)
    assert len(first) == 64 and int(first, 16) >= 0
    tables.write_table_set(sweep, _runs(), _results(), {"s_x": 0.5})  # the same tables again
    assert tables.tables_digest(sweep) == first
    tables.write_table_set(sweep, _runs(), _results().assign(mu_bar=[0.2, 0.5]), {})
    second = tables.tables_digest(sweep)
    assert second != first
    tables.write_table_set(sweep, _runs().iloc[:2], _results().assign(mu_bar=[0.2, 0.5]), {})
    assert tables.tables_digest(sweep) not in (first, second)


def test_the_catalogue_is_every_runs_events_after_its_job_and_parameters():
    events = pd.DataFrame({"t_max": [1.0, 2.0], "drop": [0.1, 0.2], "late": [0.0, 1.0]})
    cat = tables.catalogue_table([("a1", {"phi": 1.0, "Lx": 20}, events),
                                  ("b2", {"phi": 2.0, "Lx": 20}, None),
                                  ("c3", {"phi": 3.0, "Lx": 20}, events.iloc[1:])])
    assert list(cat.columns) == ["job", "Lx", "phi", "t_max", "drop", "late"]
    assert list(cat.job) == ["a1", "a1", "c3"] and list(cat.phi) == [1.0, 1.0, 3.0]
    assert list(cat.t_max) == [1.0, 2.0, 2.0] and list(cat.index) == [0, 1, 2]
    assert str(cat.late.dtype) == "boolean"                       # typed as the catalogue's
    assert tables.catalogue_table([("a1", {"phi": 1.0}, events.iloc[:0])]) is None


def _draw(root, names) -> list:
    out = root / tables.FIGURES_DIR
    paths = []
    for name in names:
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_bytes(b"a figure")
        paths.append(out / name)
    return paths


def test_figures_are_recorded_with_the_tables_they_were_drawn_from(sweep):
    out = sweep / tables.FIGURES_DIR
    paths = _draw(sweep, ["mu.png", "sub/psi.pdf"])
    tables.record_figures(sweep, out, paths[::-1], where={"k_e": 10.0}, complete=False)
    record = json.loads((out / tables.FIGURES_RECORD).read_text())
    assert record == {"tables_sha256": tables.tables_digest(sweep), "where": {"k_e": 10.0},
                      "complete": False, "files": ["mu.png", "sub/psi.pdf"]}
    tables.record_figures(sweep, out, paths, where={}, digest="d" * 64)
    record = json.loads((out / tables.FIGURES_RECORD).read_text())
    assert record["tables_sha256"] == "d" * 64 and record["where"] is None
    assert record["complete"] is True


def test_figures_of_tables_that_changed_are_retired_and_no_others(sweep):
    out = sweep / tables.FIGURES_DIR
    paths = _draw(sweep, ["mu.png", "sub/psi.pdf", "mine.png"])
    tables.record_figures(sweep, out, paths[:2])
    assert tables.retire_figures(sweep) == []                  # the same tables: current
    assert all(p.exists() for p in paths)
    tables.write_table_set(sweep, _runs(), _results().assign(mu_bar=[0.2, 0.5]), {})
    assert tables.retire_figures(sweep) == ["mu.png", "sub/psi.pdf"]
    assert [p.exists() for p in paths] == [False, False, True]   # the user's own is kept
    assert not (out / tables.FIGURES_RECORD).exists()
    assert tables.retire_figures(sweep) == []                  # no record left: nothing


def test_retiring_figures_never_follows_a_name_out_of_the_figures_directory(sweep, tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    victim = outside / "victim.png"
    victim.write_bytes(b"the user's")
    out = sweep / tables.FIGURES_DIR
    out.mkdir()
    (out / "link").symlink_to(outside)
    (out / tables.FIGURES_RECORD).write_text(json.dumps({
        "tables_sha256": "stale", "files": [str(victim), "../../outside/victim.png",
                                            "link/victim.png", 7, "gone.png"]}))
    assert tables.retire_figures(sweep) == []
    assert victim.read_bytes() == b"the user's"
    assert not (out / tables.FIGURES_RECORD).exists()          # the stale record itself goes
    # a figures directory that is a link: nothing in it is the sweep's to remove
    (out / "link").unlink()
    os.rename(out, tmp_path / "elsewhere")
    out.symlink_to(tmp_path / "elsewhere")
    (out / "mu.png").write_bytes(b"a figure")
    (out / tables.FIGURES_RECORD).write_text(json.dumps({"tables_sha256": "stale",
                                                         "files": ["mu.png"]}))
    assert tables.retire_figures(sweep) == []
    assert (out / "mu.png").exists() and (out / tables.FIGURES_RECORD).exists()


@pytest.mark.parametrize("record", ["{", '{"files": ["mu.png"]}', '["mu.png"]',
                                    '{"tables_sha256": "stale", "files": "mu.png"}'])
def test_an_unreadable_record_of_figures_retires_nothing(sweep, record):
    (path,) = _draw(sweep, ["mu.png"])
    (sweep / tables.FIGURES_DIR / tables.FIGURES_RECORD).write_text(record)
    tables.retire_figures(sweep)
    assert path.exists()
