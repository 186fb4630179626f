"""The sweep's results from its runs' summaries: ``runs.csv`` (one row per finished run, every
scalar of its summary) and ``results.csv`` (one row per point of the grid: the mean over seeds
and its error of every key bkflow.analysis.summary_keys declares ``averaged``; the seeds'
states)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from bkflow.analysis import summary_keys
from bkflow.model.params import RunSpec
from bkflow.observables.states import STATE_NAMES, SWITCHING
from bkflow.store.tables import NOT_GROUPED, write_table_set

#: summary fields averaged over seeds in results.csv (mean and standard error), from the
#: declarations (their ``averaged`` keys)
RESULT_FIELDS = summary_keys.averaged_keys()
#: result fields whose runs carry their own standard error (``<field>_err``, covering the
#: switching between states: bkflow.observables.states): results.csv gives the mean of those
#: as ``<field>_err_within_run``, and the point's error ``<field>_err``, the larger of the
#: seeds' standard error and the runs' own errors combined, sqrt(sum err_i^2) / n: three seeds
#: that happen to sit in one state agree closely, and their scatter alone would understate it
WITHIN_RUN_ERRORS = summary_keys.WITHIN_RUN_ERRORS
#: what results.csv counts of its seeds' runs: each verdict, and those switching between
#: states (any of bkflow.observables.states.SWITCHING)
STATE_COUNTS = ("steady", "drifting", "metastable", "switching")
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
    params = [f for f in RunSpec.__dataclass_fields__ if f not in NOT_GROUPED]
    rows = []
    for key, g in runs.groupby(params, sort=True, dropna=False):
        row = dict(zip(params, key))
        row["N"] = int(row["Lx"] * row["Ly"])
        row["n_seeds"] = len(g)
        row.update(_means(g))
        row.update(_errors(g, row))
        regimes = g["regime"].dropna()
        row["regime"] = regimes.mode().iloc[0] if len(regimes) else None
        row.update(_state_counts(g))
        rows.append(row)
    first = ["phi", "Lx", "Ly", "N", "n_seeds"]
    df = pd.DataFrame(rows)
    return df[first + [c for c in df.columns if c not in first]].sort_values(
        ["Lx", "Ly", "phi"], kind="stable").reset_index(drop=True)


def _means(g: pd.DataFrame) -> dict:
    """The seeds' mean and standard error of each result field (NaN where not recorded)."""
    row = {}
    for f in RESULT_FIELDS:
        if f not in g:  # a field the runs did not record
            row[f] = row[f"{f}_sem"] = math.nan
            continue
        v = pd.to_numeric(g[f], errors="coerce").to_numpy(dtype=float)
        v = v[np.isfinite(v)]
        row[f] = v.mean() if len(v) else math.nan
        row[f"{f}_sem"] = v.std(ddof=1) / math.sqrt(len(v)) if len(v) > 1 else math.nan
    return row


def _errors(g: pd.DataFrame, means: dict) -> dict:
    """The runs' own errors of WITHIN_RUN_ERRORS, and the point's error of each."""
    row = {}
    for f in WITHIN_RUN_ERRORS:
        err = pd.to_numeric(g[f"{f}_err"], errors="coerce").to_numpy(dtype=float) \
            if f"{f}_err" in g else np.full(1, math.nan)
        ok = err[np.isfinite(err)]
        row[f"{f}_err_within_run"] = float(ok.mean()) if len(ok) else math.nan
        combined = math.sqrt((ok ** 2).sum()) / len(ok) if len(ok) else math.nan
        sem = means[f"{f}_sem"]
        row[f"{f}_err"] = float(np.nanmax([sem, combined])) \
            if math.isfinite(sem) or math.isfinite(combined) else math.nan
    return row


def _state_counts(g: pd.DataFrame) -> dict:
    """The seeds' runs that are trend-free, in each verdict, and the point's state."""
    stationary = g["stationary"].fillna(False).astype(bool) if "stationary" in g \
        else pd.Series(False, index=g.index)
    row = {"n_stationary": int(stationary.sum())}
    states = g["state"].fillna("drifting") if "state" in g \
        else pd.Series("drifting", index=g.index)
    for name in STATE_COUNTS:
        row[f"n_{name}"] = int(states.isin(SWITCHING).sum()) if name == "switching" \
            else int((states == name).sum())
    row["state"] = point_state(states)
    return row


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


def write_tables(root, finished_runs, settings: dict) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The sweep's tables of its finished runs ((job id, state point, summary) each), written
    into ``root`` as one set (``bkflow.store.tables.write_table_set``); returns them."""
    runs = runs_table(finished_runs)
    results = results_table(runs)
    write_table_set(root, runs, results, settings)
    return runs, results
