"""The tables of a sweep: ``runs.csv`` (one row per finished run) and ``results.csv`` (one
row per point of the grid, mean and standard error over seeds), written through one writer
with one float format (``bkflow.store.formats.write_table``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from bkflow.model.params import RunSpec
from bkflow.observables.states import STATE_NAMES, SWITCHING
from bkflow.store import formats
from bkflow.store.rundir import DamagedRunError

RUNS_FILE = "runs.csv"
RESULTS_FILE = "results.csv"
#: the sweep's event catalogue as bkflow wrote it before 0.5 (a copy of its runs'
#: events.parquet with their parameters, CSV and Parquet): removed by the next collect; the
#: catalogue is now made from the runs' own when asked for (``bkflow.api.Sweep.events``)
CATALOGUE_FILE, CATALOGUE_PARQUET = "catalogue.csv", "catalogue.parquet"
#: the analysis settings every row of the tables was made under
SETTINGS_FILE = "analysis.json"
#: where bkflow plot puts a sweep's figures by default, and its record of what it drew there
FIGURES_DIR = "figures"
FIGURES_RECORD = "figures.json"
#: summary fields averaged over seeds in results.csv (mean and standard error)
RESULT_FIELDS = ("mu_bar", "mu_bar_large", "mean_stress_ratio", "psi_inf", "lx_over_ly",
                 "lx_over_ly_large", "lx_mean_over_Lx", "ly_mean_over_Ly", "drop_exponent",
                 "n_slips", "n_slips_large", "drift", "t_equil", "t_run", "phase_coherence",
                 "phase_fluctuation", "time_quiet", "time_coherent", "mean_stress_ratio_quiet",
                 "mean_stress_ratio_coherent", "mu_bar_quiet", "mu_bar_coherent")
#: result fields whose runs carry their own standard error (``<field>_err``, covering the
#: switching between states: bkflow.observables.states): results.csv gives the mean of those as
#: ``<field>_err_within_run``, and the point's error ``<field>_err``, the larger of the seeds'
#: standard error and the runs' own errors combined, sqrt(sum err_i^2) / n: three seeds that
#: happen to sit in one state agree closely, and their scatter alone would understate it
WITHIN_RUN_ERRORS = ("mu_bar", "mu_bar_large", "mean_stress_ratio")
#: what results.csv counts of its seeds' runs: each verdict, and those switching between
#: states (any of bkflow.observables.states.SWITCHING)
STATE_COUNTS = ("steady", "drifting", "metastable", "switching")
#: state-point keys that are not physics: averaged over
_NOT_GROUPED = ("seed",)
#: summary entries that are not results (nested parameters and settings, bookkeeping)
_NOT_A_RESULT = ("params", "settings", "tables", "bkflow", "analysis_revision")


def summary_row(summary: dict) -> dict:
    """The scalars of a summary, nested dicts flattened as ``key[sub]``."""
    row = {}
    for k, v in summary.items():
        if k in _NOT_A_RESULT or isinstance(v, list):
            continue
        if isinstance(v, dict):
            for kk, vv in v.items():
                row[f"{k}[{kk}]"] = vv
        else:
            row[k] = v
    return row


def runs_table(finished_runs) -> pd.DataFrame:
    """One row per run: job id, every parameter (as requested: an adaptive run's t_end is
    its cap, t_run the length it ran) and every scalar of its summary.

    ``finished_runs``: (job id, state point, summary) of every finished run."""
    rows = [{"job": job_id, **summary_row(summary), **statepoint}
            for job_id, statepoint, summary in finished_runs]
    df = pd.DataFrame(rows)
    if len(df):
        df = df.sort_values(["Lx", "Ly", "phi", "seed"], kind="stable").reset_index(drop=True)
    return df


def results_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (phi, size, and every other parameter but the seed): the mean over seeds and its
    standard error (sample standard deviation / sqrt(n); NaN for one seed) of
    ``RESULT_FIELDS``, the seeds' count, the mean within-run errors
    (``WITHIN_RUN_ERRORS``), the regime
    most seeds report, and the states of the seeds' runs (docs/model.md "Steady state"):
    ``n_steady``, ``n_switching``, ``n_drifting``, ``n_metastable``, and the point's
    ``state`` (``point_state``); ``n_stationary`` counts the runs whose stress alone is
    trend-free; ``<field>_err``: the larger of the seeds' standard error and their runs' own
    errors combined (each covering the switching)."""
    if runs.empty:
        return pd.DataFrame()
    params = [f for f in RunSpec.__dataclass_fields__ if f not in _NOT_GROUPED]
    rows = []
    for key, g in runs.groupby(params, sort=True, dropna=False):
        row = dict(zip(params, key))
        row["N"] = int(row["Lx"] * row["Ly"])
        row["n_seeds"] = len(g)
        for f in RESULT_FIELDS:
            if f not in g:  # a field the runs did not record
                row[f] = row[f"{f}_sem"] = math.nan
                continue
            v = pd.to_numeric(g[f], errors="coerce").to_numpy(dtype=float)
            v = v[np.isfinite(v)]
            row[f] = v.mean() if len(v) else math.nan
            row[f"{f}_sem"] = v.std(ddof=1) / math.sqrt(len(v)) if len(v) > 1 else math.nan
        for f in WITHIN_RUN_ERRORS:
            err = pd.to_numeric(g[f"{f}_err"], errors="coerce").to_numpy(dtype=float) \
                if f"{f}_err" in g else np.full(1, math.nan)
            ok = err[np.isfinite(err)]
            row[f"{f}_err_within_run"] = float(ok.mean()) if len(ok) else math.nan
            combined = math.sqrt((ok ** 2).sum()) / len(ok) if len(ok) else math.nan
            row[f"{f}_err"] = float(np.nanmax([row[f"{f}_sem"], combined])) \
                if math.isfinite(row[f"{f}_sem"]) or math.isfinite(combined) else math.nan
        regimes = g["regime"].dropna()
        row["regime"] = regimes.mode().iloc[0] if len(regimes) else None
        stationary = g["stationary"].fillna(False).astype(bool) if "stationary" in g \
            else pd.Series(False, index=g.index)
        row["n_stationary"] = int(stationary.sum())
        states = g["state"].fillna("drifting") if "state" in g \
            else pd.Series("drifting", index=g.index)
        for name in STATE_COUNTS:
            row[f"n_{name}"] = int(states.isin(SWITCHING).sum()) if name == "switching" \
                else int((states == name).sum())
        row["state"] = point_state(states)
        rows.append(row)
    first = ["phi", "Lx", "Ly", "N", "n_seeds"]
    df = pd.DataFrame(rows)
    return df[first + [c for c in df.columns if c not in first]].sort_values(
        ["Lx", "Ly", "phi"], kind="stable").reset_index(drop=True)


def point_state(states) -> str:
    """The state of a point of the grid from its seeds' runs: metastable when any run is (it
    still remembers its start), else drifting when any is, else the states the switching runs
    visited together (``quiet+coherent`` when they saw both between them), else steady (every
    run is); a point without runs is drifting."""
    states = list(states)
    if not states or "metastable" in states:
        return "metastable" if states else "drifting"
    if "drifting" in states:
        return "drifting"
    seen = {s for v in states if v in SWITCHING for s in v.split("+")}
    if seen:
        return "+".join(s for s in STATE_NAMES if s in seen)
    return "steady"


def _key(value):
    """A parameter as a comparable key: NaN and None alike, numbers as floats."""
    if value is None or (isinstance(value, float) and value != value):
        return None
    if isinstance(value, (bool, str)):
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value)


def rows_of(results: pd.DataFrame, specs) -> pd.DataFrame:
    """The rows of a results table that are these specs' points (every parameter but the
    seed): a directory may hold other sweeps too."""
    names = [f for f in RunSpec.__dataclass_fields__ if f not in _NOT_GROUPED
             and f in results.columns]
    keep = {tuple(_key(getattr(s, f)) for f in names) for s in specs}
    mask = [tuple(_key(r[f]) for f in names) in keep for r in results.to_dict("records")]
    return results[mask]


#: the axes every figure and printed table draws itself (phi along x, one series per size;
#: seeds averaged)
DRAWN_AXES = ("phi", "Lx", "Ly", "seed")


def varied_parameters(results: pd.DataFrame) -> list[str]:
    """The parameters besides phi, size and seed that take several values in a sweep's
    results (its --vary axes, or several sweeps in one directory)."""
    return [f for f in RunSpec.__dataclass_fields__ if f not in DRAWN_AXES and f in results
            and results[f].astype(str).nunique(dropna=False) > 1]


def write_tables(root, finished_runs, settings: dict) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Write the sweep's tables into ``root`` as one set: runs.csv and results.csv first
    (and an older bkflow's copy of the event catalogue removed: the runs' own are the
    catalogue), then analysis.json, the record of the set: the settings they were made under
    and the size and digest of each. A collect cut short (a full disk, Ctrl-C) leaves the
    record of the set before, which the new tables no longer match: readers refuse them
    (``tables_problem``), and the next collect writes the set again."""
    runs = runs_table(finished_runs)
    results = results_table(runs)
    root = Path(root)
    formats.write_table(root / RUNS_FILE, runs)
    formats.write_table(root / RESULTS_FILE, results)
    for name in (CATALOGUE_FILE, CATALOGUE_PARQUET):
        (root / name).unlink(missing_ok=True)
    members = [n for n in (RUNS_FILE, RESULTS_FILE) if (root / n).is_file()]
    formats.write_json_atomic(root / SETTINGS_FILE, {
        **settings, TABLES_KEY: {n: formats.file_record(root / n) for n in members}})
    return runs, results


#: analysis.json's entry for the record of the sweep's tables (not an analysis setting)
TABLES_KEY = "tables"


def settings_in(record: dict) -> dict:
    """The analysis settings of an analysis.json (without its record of the tables)."""
    return {k: v for k, v in record.items() if k != TABLES_KEY}


def tables_problem(root) -> str | None:
    """Why the sweep's tables are not the set its last collect wrote (None: they are): a
    member missing, cut or replaced since, or no record of them (analysis.json of an older
    bkflow, or none)."""
    import json

    root = Path(root)
    try:
        record = json.loads(formats.read_text(root / SETTINGS_FILE)).get(TABLES_KEY)
    except (OSError, ValueError, AttributeError):
        record = None
    if not isinstance(record, dict) or RUNS_FILE not in record:
        return f"{SETTINGS_FILE} does not record the tables it belongs with"
    for name, want in record.items():
        p = formats.within(root, name)   # a name the record gives: read only inside the sweep
        if p is None:
            return f"{SETTINGS_FILE} names {name!r}, which is not a table of the sweep's"
        if p.is_symlink() or not p.is_file():
            return f"{name} is missing"
        if formats.file_record(p) != want:
            return f"{name} is not the one the last collect wrote (cut, or written apart)"
    for name in (CATALOGUE_FILE, CATALOGUE_PARQUET):
        if name not in record and (root / name).exists():
            return f"{name} is not one the last collect wrote"
    return None


class StaleTablesError(DamagedRunError):
    """The sweep's tables, or its runs' analyses, are not one collect's (``tables_problem``;
    a run re-analysed apart): what bkflow collect repairs. A DamagedRunError, as the command
    line reports it."""


def check_tables(root) -> None:
    """Raise StaleTablesError naming the repair when the sweep's tables are not one set."""
    why = tables_problem(root)
    if why is not None:
        raise StaleTablesError(f"{root}: {why}; bkflow collect {formats.shell_word(root)} "
                               "writes the sweep's "
                               "tables again")


def catalogue_table(run_events) -> pd.DataFrame | None:
    """The sweep's event catalogue from (job id, state point, events DataFrame) of every
    finished run: one row per slip, the run's job id and parameters as its first columns;
    None without any event."""
    from bkflow.observables.catalogue import typed

    parts = []
    for job, statepoint, events in run_events:
        if events is None or not len(events):
            continue
        params = pd.DataFrame({"job": job, **{k: [v] * len(events) for k, v in
                                              sorted(statepoint.items())}})
        parts.append(pd.concat([params, events.reset_index(drop=True)], axis=1))
    if not parts:
        return None
    return typed(pd.concat(parts, ignore_index=True))


def read_tables(root) -> tuple[pd.DataFrame, pd.DataFrame]:
    """runs.csv and results.csv of a sweep directory, checked to be the set its last collect
    wrote (StaleTablesError otherwise; FileNotFoundError when absent, pandas' EmptyDataError
    when empty)."""
    root = Path(root)
    if not (root / RUNS_FILE).exists():
        raise FileNotFoundError(2, "No such file or directory", str(root / RUNS_FILE))
    check_tables(root)
    return formats.read_table(root / RUNS_FILE), formats.read_table(root / RESULTS_FILE)


def tables_digest(root) -> str:
    """A digest of the sweep's tables (runs.csv and results.csv): what its figures drew."""
    import hashlib

    h = hashlib.sha256()
    for name in (RUNS_FILE, RESULTS_FILE):
        h.update(formats.read_bytes(Path(root) / name))
    return h.hexdigest()


def record_figures(root, out, paths, where=None, complete: bool = True,
                   digest: str | None = None) -> None:
    """Note in ``out`` which figures were drawn from which tables (``digest``: of the tables
    as they were read, which the caller took before reading them; default: as they are now),
    of which runs (``where``), and whether the plot finished (``retire_figures``)."""
    out = Path(out)
    formats.write_json_atomic(out / FIGURES_RECORD, {
        "tables_sha256": digest or tables_digest(root), "where": where or None,
        "complete": complete,
        "files": sorted(str(Path(p).relative_to(out)) for p in paths)})


def retire_figures(root) -> list[str]:
    """Remove the figures ``bkflow plot`` drew in ``root/figures`` from tables that have since
    changed (a second sweep into the directory, a new analysis), so that no figure looks
    current that is not; the user's own files there are left. Returns the files removed."""
    import json

    from bkflow.store.formats import within

    out = within(root, FIGURES_DIR)
    if out is None:   # a link: what it holds is not the sweep's to remove
        return []
    try:
        record = json.loads(formats.read_text(out / FIGURES_RECORD))
        if record["tables_sha256"] == tables_digest(root):
            return []
        files = [f for f in record["files"] if isinstance(f, str)] \
            if isinstance(record["files"], list) else []
    except (OSError, ValueError, KeyError, TypeError):
        return []
    removed = []
    for name in files:
        p = within(out, name)   # absolute, '..' or through a link: not one of ours
        if p is None or not p.is_file():
            continue
        p.unlink()
        removed.append(name)
    record = within(out, FIGURES_RECORD)
    if record is not None:
        record.unlink(missing_ok=True)
    return removed
