"""The run directory's layout: the name of every file a run and its analysis write, and of
the columns of its tables.

This module is the only one that names a file of a run (``bkflow.store.rundir`` hands the names
on, with the ``RunDir`` that reads and checks them). The engine writes the deck, the data file
and LAMMPS's outputs into a run directory and commits the run by writing ``meta.json`` last
(atomically, with the size of every file, so a cut file is detected); the analysis reads the
run's tables and writes its own.

| file | what |
|---|---|
| ``in.bk``, ``data.bk`` | the LAMMPS deck and data file (``lmp -in in.bk`` runs it again) |
| ``params.json`` | the RunSpec of a deck written by ``bkflow deck`` |
| ``extrema.npy`` | sigma_x's turning points at the extrema threshold (observables.reduced) |
| ``blocks.npy`` | sums of sigma_x and of the contacts' phases over blocks (observables.reduced) |
| ``stress.npy`` | step, sigma_x: the raw shear stress (scenes series, full; + the ledger) |
| ``phase.npy`` | step, R, Z_re, Z_im, R2, u_mean, u_std: the raw load phases (series, full) |
| ``stress.csv``, ``phase.csv`` | the same as text, in runs of bkflow before 0.5 |
| ``psi.npy`` | Psi(t) every snapshot_nevery steps, computed in the run (order, figures, full) |
| ``snapshots.lammpstrj`` | positions every snapshot_nevery steps (scene full) |
| ``slips.npy``, ``clusters.npy`` | each slip's catalogue row and clusters, from the run (figures) |
| ``slips.lammpstrj`` | positions at every slip's maximum and minimum (+ first breaks) |
| ``fronts.bin`` | every particle's slip rate through the first slips (scenes fronts, full) |
| ``log.lammps`` | LAMMPS's log |
| ``restart.STEP.bk`` | LAMMPS's restart file of the last step: a longer run continues from it |
| ``meta.json`` | the completion record: parameters, versions, counters, sizes |
| ``summary.json`` | the analysis: every observable, the settings it was made under |
| ``events.parquet`` | the event catalogue, one row per slip (bkflow.observables.catalogue), typed |
| ``psi.csv`` | ``t,psi``: Psi(t) of a run made before bkflow computed it in the run |
| ``clusters.csv`` | one row per slip cluster (scenes clusters, events, full) |
| ``companion/`` | the companion run (RunSpec.companion), a run directory itself |
| ``.bkflow-run`` | the mark that bkflow made the directory (written first) |
| ``.bkflow.lock`` | the lock a process holds while it writes the run |

The scenes events and full add to extrema.npy and blocks.npy (and full to stress.csv) the
contact breaks and the energy ledger (bkflow.observables.reduced.LEDGER_COLUMNS) and to
slips.lammpstrj each contact's first break in the slip (column ``brk``); events.parquet then
holds the catalogue's size, shape, nucleation, front and energy columns, clusters.csv the
paper's energy argument per cluster.
"""

from __future__ import annotations

from pathlib import Path

DECK = "in.bk"
DATA = "data.bk"
PARAMS = "params.json"
#: the raw series (scenes series, full), binary: step and sigma_x (+ the ledger), step and the
#: phase statistics
SERIES_STRESS = "stress.npy"
SERIES_PHASE = "phase.npy"
#: the raw series as CSV: what bkflow wrote before 0.5 (read)
STRESS = "stress.csv"
PHASE = "phase.csv"
SNAPSHOTS = "snapshots.lammpstrj"
SLIPS = "slips.lammpstrj"
FRONTS = "fronts.bin"
#: the records of fix bk/reduce (bkflow.observables.reduced): sigma_x's turning points, the block
#: sums
EXTREMA = "extrema.npy"
BLOCKS = "blocks.npy"
#: Psi(t) computed in the run (fix bk/psi): step, psi
PSI_RECORD = "psi.npy"
#: each slip's row of the event catalogue and its clusters, computed in the run (fix bk/slips
#: ``catalogue``, scene figures)
SLIP_ROWS = "slips.npy"
CLUSTER_ROWS = "clusters.npy"
LOG = "log.lammps"
META = "meta.json"
#: LAMMPS's restart file of the run's last step (named by that step; meta.json's "restart"
#: names it): a longer run of the same parameters continues from it (bkflow.lammps.engine), never
#: simulating again what the run has
RESTART = "restart.{}.bk"
#: written while a finished run is being continued (the sizes of its files before): an
#: interrupted continuation is undone to the finished run (RunDir.undo_continuation)
CONTINUING = ".bkflow-continuing"
SUMMARY = "summary.json"
#: the event catalogue as CSV: what bkflow wrote before 0.5 beside the Parquet (read, removed
#: when the run is analysed again)
EVENTS = "events.csv"
#: the event catalogue (typed, columnar): one row per slip
EVENTS_PARQUET = "events.parquet"
PSI = "psi.csv"
CLUSTERS = "clusters.csv"
LOCK = ".bkflow.lock"
#: written when bkflow begins a run in a directory (its version and the time): the run's files
#: written after it are bkflow's to replace; one older than it, or a mark bkflow did not write,
#: is not (RunDir.foreign, bkflow.store.lock; docs/running.md "What bkflow replaces")
MARK = ".bkflow-run"
#: files signac keeps in a sweep's job directory
SIGNAC_FILES = ("signac_statepoint.json", "signac_job_document.json")
#: the files of a finished run that may change without damaging it: LAMMPS's log, which
#: `lmp -in in.bk` in the finished directory rewrites (the rest it writes again bit for bit)
MAY_CHANGE = (LOG,)
#: a file of a run's names as much older than the run's mark as this is still the run's
#: (file systems that keep times in whole or two seconds)
MARK_SLACK_S = 2.0
#: what a run writes (the engine); a partial run's are removed before it is redone
RUN_FILES = (DECK, DATA, EXTREMA, BLOCKS, PSI_RECORD, SLIP_ROWS, CLUSTER_ROWS, SERIES_STRESS,
             SERIES_PHASE, STRESS, PHASE, SNAPSHOTS, SLIPS, FRONTS, LOG, META)
#: what the analysis writes
ANALYSIS_FILES = (SUMMARY, EVENTS, EVENTS_PARQUET, PSI, CLUSTERS)
#: what ``bkflow movie`` draws from a run's fronts (one pair per slip asked for)
MOVIE_PATTERN, FRONT_MAPS_PATTERN = "movie_slip{}.gif", "fronts_slip{}.png"
#: a sweep directory keeps its runs in signac's workspace/<job id>/
WORKSPACE = "workspace"
#: the subdirectory of a run that holds its companion run (RunSpec.companion), itself a run
#: directory
COMPANION = "companion"

#: columns of the contacts' phase series (fix bk/phase)
PHASE_COLUMNS = ("t", "R", "Z_re", "Z_im", "R2", "u_mean", "u_std")
#: columns of the analysis's tables
EVENT_COLUMNS = ("t_max", "t_min", "sigma_fail", "drop", "late")
PSI_COLUMNS = ("t", "psi")
CLUSTER_COLUMNS = ("event", "t", "n_c", "l_x", "l_y")


def bookkeeping(name: str) -> bool:
    """A name bkflow leaves in any directory it writes: its lock, an atomic writer's
    temporary."""
    return name == LOCK or (name.startswith(".") and name.endswith(".tmp"))


def listing(names) -> str:
    """A few of ``names`` for a message: "a, b, c and 4 more"."""
    shown = sorted(names)
    return ", ".join(shown[:3]) + (f" and {len(shown) - 3} more" if len(shown) > 3 else "")


class RunFiles:
    """A run directory's path and the paths of its files (``file``): what each part of
    ``bkflow.store.rundir.RunDir`` stands on (its lock and claim, its readers, its analysis's
    files, its completion record)."""

    def __init__(self, path):
        self.path = Path(path)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({str(self.path)!r})"

    def file(self, name: str) -> Path:
        return self.path / name
