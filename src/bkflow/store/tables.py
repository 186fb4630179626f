"""The tables of a sweep on disk: ``runs.csv`` (one row per finished run) and ``results.csv``
(one row per point of the grid; made by ``bkflow.analysis.results``), written as one set
through one writer with one float format (``bkflow.store.formats.write_table``), their
record, the checks that they are one set, and the record of the figures drawn from them."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from bkflow.model.params import RunSpec
from bkflow.store import files, formats
from bkflow.store.errors import DamagedRunError

RUNS_FILE = "runs.csv"
RESULTS_FILE = "results.csv"
#: a sweep's copy of its runs' event catalogues with their parameters (CSV and Parquet), which
#: bkflow before 0.5 wrote beside the tables: removed by the next collect; the sweep's
#: catalogue is made from the runs' own when asked for (``bkflow.api.Sweep.events``)
CATALOGUE_FILE, CATALOGUE_PARQUET = "catalogue.csv", "catalogue.parquet"
#: the analysis settings every row of the tables was made under
SETTINGS_FILE = "analysis.json"
#: where bkflow plot puts a sweep's figures by default, and its record of what it drew there
FIGURES_DIR = "figures"
FIGURES_RECORD = "figures.json"
#: state-point keys that are not physics: averaged over
NOT_GROUPED = ("seed",)
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
    names = [f for f in RunSpec.__dataclass_fields__ if f not in NOT_GROUPED
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


def write_table_set(root, runs: pd.DataFrame, results: pd.DataFrame, settings: dict) -> None:
    """Write the sweep's tables into ``root`` as one set: runs.csv and results.csv first
    (and a copy of the event catalogue an earlier bkflow wrote beside them removed: the runs'
    own are the catalogue), then analysis.json, the record of the set: the settings they were
    made under and the size and digest of each. A collect cut short (a full disk, Ctrl-C)
    leaves the record of the set before, which the new tables no longer match: readers refuse
    them (``tables_problem``), and the next collect writes the set again."""
    root = Path(root)
    formats.write_table(root / RUNS_FILE, runs)
    formats.write_table(root / RESULTS_FILE, results)
    for name in (CATALOGUE_FILE, CATALOGUE_PARQUET):
        (root / name).unlink(missing_ok=True)
    members = [n for n in (RUNS_FILE, RESULTS_FILE) if (root / n).is_file()]
    formats.write_json_atomic(root / SETTINGS_FILE, {
        **settings, TABLES_KEY: {n: files.file_record(root / n) for n in members}})


#: analysis.json's entry for the record of the sweep's tables (not an analysis setting)
TABLES_KEY = "tables"


def settings_in(record: dict) -> dict:
    """The analysis settings of an analysis.json (without its record of the tables)."""
    return {k: v for k, v in record.items() if k != TABLES_KEY}


def sweep_analysis_settings(root) -> dict | None:
    """The analysis settings the sweep's project document records (its ``analysis_settings``,
    {} where it records none), as given; None where the document is missing or unreadable."""
    import json

    try:
        doc = json.loads(formats.read_text(Path(root) / "signac_project_document.json"))
        return dict(doc.get("analysis_settings", {}))
    except (OSError, ValueError, TypeError, AttributeError):
        return None


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
        plain = Path(name).name == name and name not in (".", "..")
        if plain and (root / name).is_symlink():
            return f"{name} is missing"   # a link in its place: not the table collect wrote
        p = files.within(root, name)   # a name the record gives: read only inside the sweep
        if p is None:
            return f"{SETTINGS_FILE} names {name!r}, which is not a table of the sweep's"
        if not p.is_file():
            return f"{name} is missing"
        if files.file_record(p) != want:
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
        raise StaleTablesError(f"{root}: {why}; bkflow collect {files.shell_word(root)} "
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

    from bkflow.store.files import within

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
