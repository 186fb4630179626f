"""A run's analysis on disk: summary.json and the tables the analysis writes beside it, their
checks (current for these settings, the tables the ones the summary made) and their readers.

``RunAnalysisFiles`` is a part of ``bkflow.store.rundir.RunDir``; the analysis itself (what
the summary holds) is ``bkflow.analysis``'s.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bkflow.model.params import RunSpec
from bkflow.model.settings import ANALYSIS_REVISION, AnalysisSettings
from bkflow.store import files, formats
from bkflow.store.errors import DamagedRunError
from bkflow.store.layout import (
    CLUSTER_ROWS,
    CLUSTERS,
    EVENTS,
    EVENTS_PARQUET,
    PSI,
    PSI_RECORD,
    SUMMARY,
    RunFiles,
)


class RunAnalysisFiles(RunFiles):
    """The analysis's files of a run directory (a part of ``RunDir``: they are checked against
    its completion record, ``RunDir.spec`` and ``RunDir.problem``, and read with its
    ``RunReaders``)."""

    def summary(self) -> dict | None:
        """summary.json, or None when there is none or it is unreadable."""
        return self._record(SUMMARY)

    def analysis_problem(self, settings: AnalysisSettings | None = None,
                         spec: RunSpec | None = None) -> str | None:
        """Why the analysis here is missing or stale (None when it is current): no or a cut
        summary.json, one made by another revision of the analysis (ANALYSIS_REVISION) or
        under other settings than ``settings`` (resolved for this run), for other parameters
        than ``spec``, or a table it wrote gone."""
        s = self.summary()
        if s is None:
            return f"no {SUMMARY}" if not self.file(SUMMARY).exists() \
                else f"{SUMMARY} unreadable"
        if "mu_bar" not in s or "settings" not in s or "params" not in s:
            return f"{SUMMARY} is not a bkflow summary"
        spec = spec or self.spec()
        if s.get("analysis_revision") != ANALYSIS_REVISION:
            return (f"{SUMMARY} made by analysis revision {s.get('analysis_revision')}, "
                    f"this bkflow's is {ANALYSIS_REVISION}")
        wanted = (settings or AnalysisSettings()).resolved(spec).to_dict()
        if s["settings"] != formats.json_ready(wanted):
            changed = sorted(k for k in wanted if s["settings"].get(k) != formats.json_ready(
                wanted[k]))
            return f"{SUMMARY} made under other analysis settings ({', '.join(changed)})"
        if s["params"] != formats.json_ready(spec.to_dict()):
            return f"{SUMMARY} belongs to other parameters"
        return self.table_problem(s)

    def only_analysis_left(self, spec: RunSpec,
                           settings: AnalysisSettings | None = None) -> bool:
        """Whether this directory holds the finished, intact run of ``spec`` (as requested)
        whose analysis under ``settings`` is missing or stale: the same command again after
        its analysis was cut short has only that left to do."""
        meta = self.meta() if self.is_complete() else None
        return (meta is not None and meta.get("requested") == spec.to_dict()
                and self.problem() is None and self.analysis_problem(settings) is not None)

    def kept_settings(self) -> AnalysisSettings:
        """The settings of the run's last analysis where it was made by this bkflow's
        analysis (``bkflow analyze DIR --analysis ...``), else the defaults: what a run
        command that does not name settings analyses the run under again."""
        s = self.summary()
        if not s or s.get("analysis_revision") != ANALYSIS_REVISION or \
                not isinstance(s.get("settings"), dict):
            return AnalysisSettings()
        try:
            return AnalysisSettings.from_dict(s["settings"])
        except (TypeError, ValueError):
            return AnalysisSettings()

    def write_analysis(self, summary: dict, tables: dict) -> dict:
        """Write the analysis's tables, then summary.json (last: it lists the tables)."""
        self.file(SUMMARY).unlink(missing_ok=True)
        for name in (EVENTS, EVENTS_PARQUET, PSI, CLUSTERS):
            self.file(name).unlink(missing_ok=True)
        for name, table in tables.items():
            if name == EVENTS:   # a table for programs: stored once, as Parquet
                from bkflow.observables.catalogue import typed

                formats.write_parquet(self.file(EVENTS_PARQUET), typed(table))
            else:
                formats.write_table(self.file(name), table)
        tables = {EVENTS_PARQUET if name == EVENTS else name: t for name, t in tables.items()}
        # the record last, with the size and digest of every table it made: a table cut, emptied
        # or replaced since is known (``table_problem``), and redone by whichever command needs
        # it (analyze, collect, sweep)
        summary = {**summary, "tables": sorted(tables), "analysis_revision": ANALYSIS_REVISION,
                   "table_files": {name: files.file_record(self.file(name)) for name in tables}}
        formats.write_json_atomic(self.file(SUMMARY), summary)
        return formats.json_ready(summary)

    def table_problem(self, summary: dict | None = None) -> str | None:
        """Why the analysis's tables are not the ones its summary.json made (None: they are):
        one missing, cut, emptied or replaced (its size, then its digest, changed), or a
        summary without the record of them (one written before bkflow recorded its tables).
        The tables are one set with their summary: a reader of one checks them all."""
        s = summary if summary is not None else self.summary()
        if s is None:
            return f"no {SUMMARY}"
        record = s.get("table_files")
        if not isinstance(record, dict):
            return f"{SUMMARY} does not record its tables"
        for name in s.get("tables", []):
            p = self.file(name)
            if p.is_symlink() or not p.is_file():
                return f"{name} is missing"
            want = record.get(name) or {}
            if p.stat().st_size != want.get("bytes") or files.file_record(p) != want:
                return f"{name} is not the table the analysis wrote (cut, emptied or replaced)"
        return None

    def _checked(self, name: str) -> Path:
        """The path of the analysis's table ``name``, after checking it is the one its summary
        recorded (DamagedRunError otherwise, naming the repair)."""
        why = self.table_problem()
        if why is not None:
            raise DamagedRunError(f"{self.path}: {why}; bkflow analyze "
                                  f"{files.shell_word(self.path)} (or bkflow "
                                  "collect, for a sweep) makes the analysis again")
        return self.file(name)

    def _lists(self, name: str) -> bool:
        """Whether the analysis wrote its table ``name``: the file is there, or summary.json
        lists it (then it is missing: damage, which ``_checked`` names)."""
        if self.file(name).exists():
            return True
        s = self.summary()
        return s is not None and name in (s.get("tables") or [])

    def read_events(self):
        """The event catalogue as a typed DataFrame (events.parquet; events.csv where there is
        no Parquet copy): one row per slip, columns ``EVENT_COLUMNS`` and those of
        bkflow.observables.catalogue the scene recorded."""
        import pandas as pd

        from bkflow.observables.catalogue import typed

        if self.file(EVENTS_PARQUET).exists():
            return pd.read_parquet(self._checked(EVENTS_PARQUET), engine="pyarrow")
        return typed(formats.read_table(self._checked(EVENTS)))

    def has_events(self) -> bool:
        """Whether the analysis wrote the event catalogue (events.parquet; events.csv of a run
        analysed before bkflow 0.5): there, or listed by summary.json (then missing: damage,
        said by ``read_events``)."""
        if self.file(EVENTS).exists() or self.file(EVENTS_PARQUET).exists():
            return True
        s = self.summary()
        return s is not None and EVENTS_PARQUET in (s.get("tables") or [])

    def read_psi_table(self):
        """Psi(t) as a table in time (t, psi), what the figures and ``bkflow.load_run`` read:
        from the run's own record (``read_psi_record``: steps and Psi as fix bk/psi computed
        them), or the psi.csv the analysis wrote from the snapshots of a run made before bkflow
        computed Psi in the run; None when the run recorded neither."""
        import pandas as pd

        if self.file(PSI_RECORD).exists():
            spec = self.spec()
            steps, psi = self.read_psi_record(spec)
            return pd.DataFrame({"t": steps * spec.dt, "psi": psi})
        return formats.read_table(self._checked(PSI)) if self._lists(PSI) else None

    def read_clusters(self):
        """One row per slip cluster of the analysed slips (``CLUSTER_COLUMNS`` and n_x, n_y,
        slip, bond_change, eq2_estimate): the run's clusters.npy joined to its events (scene
        figures), or the clusters.csv the analysis made from the slips' frames; None when the
        run recorded neither."""
        import pandas as pd

        if self.file(CLUSTER_ROWS).exists():
            summary = self.summary()
            if summary is None:
                return None
            events = self.read_events()
            spec = self.spec()
            # an event by the steps of its maximum and minimum (a slip of another threshold
            # than the analysis's may share its maximum): as the analysis matched them
            at = {(int(round(a / spec.dt)), int(round(b / spec.dt))): k
                  for k, (a, b) in enumerate(zip(events["t_max"], events["t_min"]))
                  if a >= summary["t_transient"]}
            slips, rows = self.read_slip_rows(spec)
            end = dict(zip(slips["step_max"].tolist(), slips["step_min"].tolist()))
            steps = [(int(s), int(end.get(s, -1))) for s in rows["step_max"].tolist()]
            keep = np.array([s in at for s in steps], bool)
            out = {"event": [at[s] for s, k in zip(steps, keep) if k]}
            out["t"] = events["t_max"].to_numpy()[out["event"]]
            for c in ("n_c", "l_x", "l_y", "n_x", "n_y", "slip", "bond_change", "eq2_estimate"):
                out[c] = rows[c][keep]
            return pd.DataFrame(out)
        return formats.read_table(self._checked(CLUSTERS)) if self._lists(CLUSTERS) else None
