"""Runs and sweeps as Python objects, for notebooks: ``bkflow.load_run(dir)`` and
``bkflow.load_sweep(dir)``:

    sweep = bkflow.load_sweep("runs/sweep")
    sweep.results[["phi", "N", "mu_bar", "mu_bar_err", "state"]]
    sweep.figure("fig2a")
    run = sweep.run(0)                      # the first row of sweep.runs
    run.stress.plot(x="t", y="sigma_x")

Tables are pandas DataFrames read from the files bkflow wrote (nothing is recomputed);
figures are ``matplotlib.figure.Figure`` objects made without pyplot: building one neither
switches the backend, nor changes rcParams, nor touches the figures a user has open
(``bkflow.figures.style.Figures``). A notebook displays the Figure it is given; in a script, save
it (``fig.savefig("f.png")``): it belongs to no pyplot window.
"""

from __future__ import annotations

import functools
from pathlib import Path

import pandas as pd

from bkflow.figures.catalogue import FIGURES, figure
from bkflow.figures.data import SweepData
from bkflow.figures.fronts import front_figure, front_frame_figure, front_movie, run_description
from bkflow.figures.style import Figures, PlotError, style, value_label
from bkflow.model.params import RunSpec, transient_step
from bkflow.model.settings import AnalysisSettings
from bkflow.store import formats
from bkflow.store.errors import AnalysisError, DamagedRunError
from bkflow.store.files import shell_word
from bkflow.store.layout import SUMMARY
from bkflow.store.rundir import RunDir, sweep_run_dir


class Run:
    """A finished run directory (``bkflow run``, a sweep's job, or a deck run with ``lmp``):
    its parameters, its record, its analysis and its tables."""

    def __init__(self, path):
        self.path = Path(path)
        self._rd = RunDir(self.path)
        if not self._rd.is_complete():
            why = self._rd.finished_standalone()
            if why is not None:
                raise AnalysisError(why)
        self.spec: RunSpec = self._rd.spec()

    def __repr__(self) -> str:
        s = self.summary or {}
        mu = s.get("mu_bar")
        return (f"Run({str(self.path)!r}: phi = {self.spec.phi:g}, "
                f"{self.spec.Lx}x{self.spec.Ly}, seed {self.spec.seed}, t_end = "
                f"{self.spec.t_end:g}" + (f", mu_bar = {mu:.4f}" if mu is not None else "")
                + (f", {s.get('state', 'n/a')}" if s else ", not analysed") + ")")

    @property
    def meta(self) -> dict | None:
        """meta.json: parameters, versions, the path and kernel that ran, wall time."""
        return self._rd.meta()

    def _intact(self) -> RunDir:
        """The run directory, after checking that the run is the one its record says
        (DamagedRunError otherwise, as the command line reports it: never a stale result)."""
        if self._rd.is_complete():
            why = self._rd.problem()
            if why is not None:
                raise DamagedRunError(f"{self.path}: {why}: {self._rd.damage_advice()}")
        return self._rd

    @property
    def summary(self) -> dict | None:
        """summary.json (None before the analysis); ``analyze`` makes it. A summary whose
        tables are not the ones it made, or of a damaged run, raises DamagedRunError."""
        rd = self._intact()
        s = rd.summary()
        why = None if s is None else rd.table_problem(s)
        if why is None and s is not None and rd.is_complete() and \
                s.get("params") != formats.json_ready(rd.spec().to_dict()):
            why = (f"{SUMMARY} is the analysis of other parameters (the run was continued "
                   "since, or redone)")
        if why is not None:
            raise DamagedRunError(f"{self.path}: {why}; bkflow analyze "
                                  f"{shell_word(self.path)} makes the analysis again")
        return s

    def analyze(self, **settings) -> dict:
        """Analyse the run (``bkflow analyze``) under these analysis settings, e.g.
        ``run.analyze(s_x=0.05)``; returns the summary."""
        from bkflow.analysis.summary import analyze

        return analyze(self.path, AnalysisSettings(**settings))

    @property
    def stress(self) -> pd.DataFrame:
        """``t``, ``sigma_x``: the shear stress, the raw series where the run's scene kept it
        (series, full), else its turning points (every maximum and minimum of the drops above
        the recorded threshold: extrema.npy)."""
        t, sigma = self._intact().stress_outline(self.spec)
        return pd.DataFrame({"t": t, "sigma_x": sigma})

    @property
    def phase(self) -> pd.DataFrame | None:
        """``t, R, Z_re, Z_im, R2, u_mean, u_std``: the contacts' load phases, the raw series
        where the run's scene kept it (phase.npy), else their means over the blocks of
        blocks.npy; None for a run directory without a phase record."""
        p = self._intact().phase_series(self.spec)
        return None if p is None else pd.DataFrame(p)

    @property
    def blocks(self) -> pd.DataFrame:
        """The run's block means (blocks.npy, bkflow.observables.reduced): ``t`` (each block's
        start), ``sigma_x`` and, where recorded, the contacts' phase statistics: what the analysis
        reads of the series."""
        t, sigma, phase = self._intact().read_reduced(self.spec).series()
        df = pd.DataFrame({"t": t, "sigma_x": sigma})
        if phase is not None:
            df = df.merge(pd.DataFrame(phase), on="t", how="left")
        return df

    @property
    def events(self) -> pd.DataFrame | None:
        """The event catalogue, one row per slip, typed (events.parquet, or events.csv; None
        before the analysis): docs/model.md "The event catalogue"."""
        if not self._rd.has_events():
            return None
        _ = self.summary   # the catalogue is the analysis's: refused when it is stale
        return self._intact().read_events()

    @property
    def psi(self) -> pd.DataFrame | None:
        """Psi(t) (scenes order, full; None otherwise)."""
        return self._intact().read_psi_table()

    @property
    def clusters(self) -> pd.DataFrame | None:
        """One row per slip cluster (scenes clusters, full; None otherwise)."""
        _ = self.summary   # the clusters are read with the analysis's events
        return self._intact().read_clusters()

    @functools.cached_property
    def fronts(self):
        """The rupture fronts the run recorded (scenes fronts, full) of the slips after the
        run's transient: a list of ``bkflow.store.formats.Front``, one per slip, in the order
        of the slips (read once: the file of a long run holds hundreds of megabytes). An
        adaptive run records from the transient of its shortest length (its end is not known
        in advance); the slips before the transient of the length it ran are left out, so
        that slip 0 is the first after the transient for every run."""
        try:  # the analysis' transient (its settings may move it) where it is current
            s = self.summary
        except DamagedRunError:
            s = None
        t0 = s.get("t_transient") if s else None
        if t0 is None:
            t0 = transient_step(self.spec.transient, self.spec.n_steps) * self.spec.dt
        return [f for f in self._rd.read_fronts() if f.step_max * self.spec.dt >= t0]

    def _front(self, slip: int):
        fronts = self.fronts
        if not fronts:
            raise PlotError(f"{self.path}: no rupture fronts recorded (run with --scene fronts "
                            "or full)")
        if not -len(fronts) <= slip < len(fronts):
            raise PlotError(f"{self.path}: slip {slip} not recorded; {len(fronts)} slips "
                            f"have fronts (0..{len(fronts) - 1})")
        return fronts[slip]

    def _front_title(self, slip: int, f) -> str:
        """The title of a slip's pictures: the layer, the slip and its times, and on a second
        line the run's start and protocol (``bkflow.figures.fronts.run_description``)."""
        s = self.spec
        return (rf"$\phi$ = {value_label(s.phi)}, {s.Lx}x{s.Ly}, slip {slip} (t = "
                f"{f.step_max * s.dt:.1f} to {f.step_min * s.dt:.1f})"
                + (", its first samples dropped" if f.truncated else "")
                + "\n" + run_description(s))

    def front_figure(self, slip: int = 0):
        """x-t and y-t maps of the slip rate through recorded slip ``slip`` (a Figure)."""
        f = self._front(slip)
        s = self.spec
        return front_figure(f, s.Lx, s.Ly, s.dt, title=self._front_title(slip, f))

    def front_frame(self, slip: int = 0, frame: int = 0):
        """One frame of recorded slip ``slip``'s movie (``frame``: which recorded sample) as
        a Figure: the layer coloured by slip rate, with axes, colour bar and title."""
        f = self._front(slip)
        s = self.spec
        return front_frame_figure(f, s.Lx, s.Ly, s.dt, self._front_title(slip, f), frame)[0]

    def movie(self, slip: int = 0, path=None, fps: float = 15.0) -> Path:
        """An animated GIF of recorded slip ``slip``: the layer coloured by slip rate.
        Default path: ``movie_slip<K>.gif`` in the run directory. Returns the path."""
        f = self._front(slip)
        path = Path(path) if path is not None else self._rd.movie_file(slip)
        front_movie(f, self.spec.Lx, self.spec.Ly, self.spec.dt, path, fps,
                    title=self._front_title(slip, f))
        return path

    # complexity: one figure's three panels, each drawn or said to be empty in place
    def figure(self, window: float | None = None):
        """What a physicist looks at first, as a Figure: the stress's block means
        (sigma_x / sigma_n A over blocks of 20 time units, however long the run), the analysed
        window shaded, the blocks whose contacts were quiet marked; beneath, the contacts'
        coherence R per block with the quiet threshold sqrt(pi / 4N); beside, the distribution
        of the slips' stress drops after the transient (the fraction above each drop, log-log).
        ``window``: the last so many time units of the time panels (default: the whole run)."""
        import numpy as np

        from bkflow.observables.states import r_independent

        b = self.blocks
        if window is not None:
            b = b[b.t >= b.t.iloc[-1] - window]
        s = self.summary or {}
        ratio = b.sigma_x / self.spec.stress_unit
        quiet = (b.R < r_independent(self.spec.N)).to_numpy() if "R" in b else None
        with style():
            fig = Figures().figure(figsize=(7.2, 3.6))
            grid = fig.add_gridspec(2, 2, width_ratios=[2.2, 1], height_ratios=[1.4, 1])
            top = fig.add_subplot(grid[0, 0])
            top.plot(b.t, ratio, lw=0.6, color="black", label="block means")
            if quiet is not None and quiet.any():
                top.plot(b.t[quiet], ratio[quiet], "o", ms=1.4, color="tab:orange", alpha=0.7,
                         lw=0, label="quiet blocks (R below its threshold)")
            # the range of the blocks, not of the start's first one (a start far off the
            # steady stress would flatten the rest)
            lo, hi = np.percentile(ratio, [1, 99]) if len(ratio) > 20 else (ratio.min(),
                                                                             ratio.max())
            pad = 0.25 * (hi - lo) if hi > lo else 0.01 * abs(hi) or 0.01
            top.set_ylim(lo - pad, hi + pad)
            t0 = s.get("t_transient")
            if isinstance(t0, (int, float)):
                top.axvspan(max(t0, float(b.t.iloc[0])), float(b.t.iloc[-1]), color="0.92",
                            zorder=0, label="analysed window")
            top.set_ylabel(r"$\sigma_x/\sigma_n A$")
            top.tick_params(labelbottom=False)
            fig.suptitle(rf"$\phi$ = {value_label(self.spec.phi)}, {self.spec.Lx}x{self.spec.Ly}, "
                         f"seed {self.spec.seed}" + (f": {s['state']}" if s.get("state")
                                                     else ""), x=0.01, ha="left", fontsize=8)
            top.legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=3, fontsize=6,
                       frameon=False, borderaxespad=0.1, handletextpad=0.3, columnspacing=1.0)
            low = fig.add_subplot(grid[1, 0], sharex=top)
            if "R" in b:
                low.plot(b.t, b.R, lw=0.6, color="indigo")
                low.axhline(r_independent(self.spec.N), color="tab:orange", lw=0.8, ls="--")
                low.set_ylim(0, max(1.02 * float(b.R.max()), 2 * r_independent(self.spec.N)))
            else:
                low.text(0.5, 0.5, "no phase record", transform=low.transAxes, ha="center",
                         fontsize=7)
            low.set_ylabel("R (block)")
            low.set_xlabel(r"t ($\sqrt{m/k_d}$)")
            drops = fig.add_subplot(grid[:, 1])
            ev = self.events
            d = np.array([])
            if ev is not None and len(ev) and isinstance(t0, (int, float)):
                d = np.sort(ev["drop"][ev["t_max"] >= t0].to_numpy(float))
                d = d[d > 0] / self.spec.stress_unit
            if len(d):
                drops.loglog(d, 1.0 - np.arange(len(d)) / len(d), lw=0.9, color="tab:red")
                drops.set_title(f"{len(d)} slips after the transient", fontsize=7)
            else:
                drops.text(0.5, 0.5, "no slips after the transient" if s else
                           f"not analysed:\nbkflow analyze {shell_word(self.path)}",
                           transform=drops.transAxes, ha="center", fontsize=7)
            from matplotlib.ticker import NullFormatter

            drops.xaxis.set_minor_formatter(NullFormatter())
            drops.set_xlabel(r"drop $\Delta\sigma/\sigma_n A$")
            drops.set_ylabel("fraction of drops above")
        return fig


class Sweep:
    """A sweep directory (``bkflow sweep --out DIR``): its tables, its runs and its figures.
    ``where`` ({column: value}) keeps the runs of those parameters only."""

    def __init__(self, path, where: dict | None = None):
        self.path = Path(path)
        self._data = SweepData(self.path, where)

    def __repr__(self) -> str:
        r = self.results
        return (f"Sweep({str(self.path)!r}: {len(self.runs)} runs, {len(r)} points, "
                f"{int(r.n_steady.sum())} of {int(r.n_seeds.sum())} runs steady)")

    @property
    def runs(self) -> pd.DataFrame:
        """runs.csv: one row per run (parameters and summary)."""
        return self._data.runs

    @property
    def results(self) -> pd.DataFrame:
        """results.csv: means over seeds with standard errors, one row per point."""
        return self._data.results

    @property
    def events(self) -> pd.DataFrame | None:
        """The sweep's event catalogue: one row per slip of every run in runs.csv, the run's
        job id and parameters first (None when no run has events), made from the runs' own
        catalogues (workspace/JOB/events.parquet: stored once; DuckDB or polars read them
        there too, with runs.csv's job column to join the parameters)."""
        from bkflow.store.layout import SIGNAC_FILES
        from bkflow.store.tables import catalogue_table, check_tables
        from bkflow.sweeps.project import LENGTH

        check_tables(self.path)   # runs.csv as the last collect wrote it, or a typed error
        parts = []
        for job in self.runs.job:
            rd = sweep_run_dir(self.path, job)
            why = rd.problem()
            try:
                statepoint = formats.read_json(rd.file(SIGNAC_FILES[0]))
                if rd.file(SIGNAC_FILES[1]).exists():   # the length a later sweep asked
                    statepoint.update(formats.read_json(rd.file(SIGNAC_FILES[1])).get(
                        LENGTH, {}))
            except (OSError, ValueError) as exc:
                why = why or f"its parameters are unreadable ({exc})"
            if why is not None:
                raise DamagedRunError(f"{rd.path}: {why}; bkflow sweep (the same command) "
                                      f"or bkflow collect {shell_word(self.path)} redoes it")
            parts.append((job, statepoint, rd.read_events() if rd.has_events() else None))
        return catalogue_table(parts)

    #: the figures ``figure`` draws (short names work too: fig2a, drops)
    figures = tuple(FIGURES)

    def figure(self, name: str):
        """The paper's figure ``name`` (see ``figures``) of this sweep, as a Figure."""
        return figure(self._data, name)

    def run(self, which) -> Run:
        """A run of the sweep: an index into ``runs`` (negative from the end) or a job
        id."""
        if isinstance(which, int):
            if not -len(self.runs) <= which < len(self.runs):
                raise IndexError(f"{self.path}: run {which} is not there; the sweep has "
                                 f"{len(self.runs)} runs (0..{len(self.runs) - 1})")
            job = self.runs.iloc[which]["job"]
        else:
            job = str(which)
            if job not in set(self.runs.job):
                raise KeyError(f"{self.path}: no run with job id {job!r} in runs.csv")
        return Run(sweep_run_dir(self.path, job).path)


#: the figure ``bkflow plot RUN_DIR`` writes of one run (``Run.figure``)
RUN_FIGURE = "run"


def plot_run(run_dir, out=None, formats=("png", "pdf")) -> list[Path]:
    """``bkflow plot RUN_DIR``: the run's figure (``Run.figure``) as ``out/run.FMT`` (default:
    in the run directory), atomically, never over a user's file (PlotError)."""
    from bkflow.figures.writer import save_figure
    from bkflow.store.files import foreign_file

    out = Path(run_dir) if out is None else Path(out)
    for fmt in formats:
        why = foreign_file(out / f"{RUN_FIGURE}.{fmt}")
        if why is not None:
            raise PlotError(why)
    try:
        fig = load_run(run_dir).figure()
    except (AnalysisError, DamagedRunError) as exc:
        raise PlotError(str(exc)) from None
    out.mkdir(parents=True, exist_ok=True)
    return save_figure(fig, out, RUN_FIGURE, formats)


def load_run(path) -> Run:
    """The finished run in directory ``path`` (``Run``)."""
    return Run(path)


def load_sweep(path, where: dict | None = None) -> Sweep:
    """The sweep in directory ``path`` (``Sweep``)."""
    return Sweep(path, where)
