"""A sweep's data as the figures read it: its tables (``runs.csv``, ``results.csv``), the runs
of a selection (``where``), each run's files through ``bkflow.store.rundir`` (checked against its
completion record), the points' error bars and states. Every figure of one plot comes from one
analysis (``SweepData`` refuses tables whose runs were analysed under other settings); nothing
here analyses.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from bkflow.figures.style import PlotError
from bkflow.model.checks import SpecError
from bkflow.model.settings import AnalysisSettings
from bkflow.store.files import shell_word
from bkflow.store.formats import read_text
from bkflow.store.rundir import RunDir, sweep_run_dir
from bkflow.store.tables import (
    SETTINGS_FILE,
    StaleTablesError,
    read_tables,
    settings_in,
    sweep_analysis_settings,
)


def nearest_log(values, target) -> float:
    """The one of ``values`` nearest ``target`` on a log scale."""
    values = np.asarray(sorted(set(values)), dtype=float)
    return float(values[np.argmin(np.abs(np.log10(values) - math.log10(target)))])


def point_errors(g: pd.DataFrame, field: str) -> np.ndarray:
    """The point's error: for the fields whose runs carry their own error
    (bkflow.analysis.results.WITHIN_RUN_ERRORS) the larger of the seeds' standard error and the
    runs' errors combined (``<field>_err``, covering the switching between states); for the others
    the seeds' standard error; where a point has one seed, the run's own error."""
    sem = (g[f"{field}_err"] if f"{field}_err" in g else g[f"{field}_sem"]).to_numpy(
        dtype=float)
    own = f"{field}_err_within_run"
    if own in g:
        sem = np.where(np.isfinite(sem), sem, g[own].to_numpy(dtype=float))
    return np.where(np.isfinite(sem), sem, 0.0)


def where_of(combo: dict) -> dict:
    """A combination of the tables' varied parameters, {column: its cells' text}, as a
    ``where``: none, nan or nothing (a parameter left unset) as None, a number as a float,
    true/false as a boolean, a word as itself: the values ``bkflow plot --where`` gives."""
    out = {}
    for key, text in combo.items():
        t = str(text).strip()
        if not t or t.lower() in ("none", "nan"):
            out[key] = None
            continue
        try:
            out[key] = float(t)
        except ValueError:
            out[key] = {"true": True, "false": False}.get(t.lower(), t)
    return out


def _select(df: pd.DataFrame, where: dict) -> pd.DataFrame:
    """The rows of ``df`` whose columns hold the values of ``where`` ({column: value}, or
    {column: [values]} for any of them)."""
    for key, value in where.items():
        if key not in df:
            raise PlotError(f"--where {key}=...: the tables have no column {key!r}")
        values = value if isinstance(value, (list, tuple)) else [value]
        keep = np.zeros(len(df), dtype=bool)
        for v in values:
            keep |= _matches(df[key], v)
        df = df[keep]
    return df


def _matches(col: pd.Series, value) -> np.ndarray:
    """Which cells of ``col`` hold ``value`` (None: a parameter left unset)."""
    if value is None:
        return (col.isna() | col.astype(str).str.lower().isin(("none", "nan", ""))).to_numpy()
    if isinstance(value, bool):
        return (col.astype(str).str.lower() == str(value).lower()).to_numpy()
    if isinstance(value, (int, float)):   # a number from Python, e.g. {"Lx": 20}
        return np.isclose(pd.to_numeric(col, errors="coerce"), float(value), rtol=1e-9,
                          atol=0)
    return (col.astype(str) == str(value)).to_numpy()


class SweepData:
    """The tables and per-run files of a sweep directory; ``where`` ({column: value}) keeps
    the runs of those parameters only (a directory may hold several sweeps)."""

    def __init__(self, root, where: dict | None = None):
        self.root = Path(root)
        try:
            self.runs, self.results = read_tables(self.root)
        except FileNotFoundError as exc:
            raise PlotError(f"{self.root} has no {Path(exc.filename).name}: is it a bkflow "
                            "sweep directory (bkflow sweep --out DIR)?") from None
        except pd.errors.EmptyDataError:
            raise PlotError(f"{self.root}: no finished runs to plot yet") from None
        if where:
            self.runs, self.results = _select(self.runs, where), _select(self.results, where)
            if self.runs.empty:
                raise PlotError(f"{self.root}: no finished run has "
                                + ", ".join(f"{k} = {' or '.join(map(str, v))}"
                                            if isinstance(v, (list, tuple)) else f"{k} = {v}"
                                            for k, v in where.items()))
        if self.runs.empty:
            raise PlotError(f"{self.root}: no finished runs to plot yet")
        self._check_one_analysis()
        self.sizes = sorted({(int(a), int(b)) for a, b in zip(self.runs.Lx, self.runs.Ly)},
                            key=lambda s: s[0] * s[1])

    def _check_one_analysis(self) -> None:
        """Figures come from one analysis: the tables', the sweep's (its project document)
        and every run's summary under the same settings, or none is drawn (an interrupted
        ``bkflow collect --analysis ...`` leaves some runs re-analysed and the tables old)."""
        advice = ("(an interrupted bkflow collect?): run bkflow collect "
                  f"{shell_word(self.root)} to bring "
                  "them together, then plot")
        try:
            tables = AnalysisSettings.from_dict(settings_in(json.loads(
                read_text(self.root / SETTINGS_FILE))))
        except FileNotFoundError:
            tables = AnalysisSettings()
        except (ValueError, TypeError, SpecError) as exc:
            raise PlotError(f"{self.root / SETTINGS_FILE} is unreadable ({exc}) {advice}") \
                from None
        recorded = sweep_analysis_settings(self.root)
        try:
            sweep = tables if recorded is None else AnalysisSettings.from_dict(recorded)
        except (ValueError, TypeError, AttributeError, SpecError):
            sweep = tables
        #: the analysis settings the tables were made under (the regime rule's bounds)
        self.settings = tables
        if sweep != tables:
            raise PlotError(f"{self.root}: the sweep's analysis settings are not those its "
                            f"tables were made under {advice}")
        for job in self.runs["job"]:
            rd = sweep_run_dir(self.root, job)
            if rd.problem() is None and rd.analysis_problem(tables) is not None:
                raise StaleTablesError(f"{rd.path}: {rd.analysis_problem(tables)}, not the "
                                       f"tables' {advice}")

    def run_dir(self, row) -> RunDir:
        """The run directory of a runs.csv row, checked against its completion record (a
        figure never draws a cut file)."""
        rd = sweep_run_dir(self.root, row["job"])
        why = rd.problem()
        if why is not None:
            raise PlotError(f"{rd.path}: {why}: the sweep's own command (bkflow sweep ... --out "
                            f"{shell_word(self.root)}) redoes it")
        return rd

    def runs_of(self, lx, ly, phi=None) -> pd.DataFrame:
        """The runs of size (lx, ly), of ``phi`` only if given, by seed."""
        r = self.runs[(self.runs.Lx == lx) & (self.runs.Ly == ly)]
        if phi is not None:
            r = r[np.isclose(r.phi, phi, rtol=1e-9, atol=0)]
        return r.sort_values("seed")

    def results_of(self, lx, ly) -> pd.DataFrame:
        """The points (results.csv rows) of size (lx, ly), by phi."""
        return self.results[(self.results.Lx == lx) & (self.results.Ly == ly)].sort_values("phi")


def point_states(g: pd.DataFrame) -> np.ndarray:
    """The points' states as STATE_FILL names them (the states visited: ``switching``)."""
    from bkflow.observables.states import SWITCHING

    if "state" not in g:
        return np.full(len(g), "drifting")
    states = g["state"].fillna("drifting").astype(str)
    return np.where(states.isin(SWITCHING), "switching", states.to_numpy())

