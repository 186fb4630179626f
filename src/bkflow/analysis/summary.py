"""One run's outputs turned into its summary: mu_bar, stress drops, Psi(inf), cluster shapes.

``summarize`` is pure: arrays in, a ``RunAnalysis`` out, made of one frozen result
per observable (``FrictionResult``, ``DropResult``, ``OrderResult``,
``ClusterResult``) and the tables the figures read (events, Psi(t), clusters).
``analyze`` reads a run directory through ``bkflow.store.rundir`` and writes the summary and
the tables back there. The observables are those of docs/model.md ("Observables"); the choices it
leaves open are one ``bkflow.model.settings.AnalysisSettings``, recorded (resolved for the run)
in every summary, so that a summary made under other settings is known to be stale.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from bkflow.analysis import summary_keys
from bkflow.analysis.cluster_results import cluster_from_rows, cluster_result
from bkflow.analysis.run_results import (
    ClusterResult,
    CompanionResult,
    DropResult,
    FrictionResult,
    LargeDropResult,
    OrderResult,
    StateResult,
    StationarityResult,
    threshold_key,
)
from bkflow.model.lattice import square_lattice
from bkflow.model.params import SCALED_N, STEADY_AGREEMENT, RunSpec, transient_step
from bkflow.model.settings import AnalysisSettings
from bkflow.observables import (
    catalogue,
    order,
    pair,
    reduced,
    states,
    stationarity,
    stress,
)
from bkflow.store import formats
from bkflow.store.errors import AnalysisError, DamagedRunError
from bkflow.store.layout import BLOCKS, CLUSTERS, DECK, EVENTS, EXTREMA, PARAMS, PSI
from bkflow.store.rundir import RunDir


@dataclass(frozen=True)
class RunAnalysis:
    """What ``summarize`` returns: one result per observable (None: not recorded by the
    run's scene), the resolved settings, and the run they belong to."""

    spec: RunSpec
    settings: AnalysisSettings
    events: stress.SlipEvents
    friction: FrictionResult
    steady: StationarityResult
    state: StateResult
    large: LargeDropResult
    drops: DropResult
    order: OrderResult | None = None
    clusters: ClusterResult | None = None
    # the records with the breaks and the energy ledger (scenes events, full), or None
    ledger: reduced.Reduced | None = None
    # the analysed stress series (times, sigma_x in stress units), which added observables read
    t: np.ndarray | None = None
    sigma: np.ndarray | None = None

    def summary(self) -> dict:
        """The summary row: every declared observable's keys (``summary_keys.summary``),
        parameters and settings nested."""
        t0 = self.friction.friction.t_transient
        return summary_keys.summary(summary_keys.Context(
            self.spec, self.settings, self.t, self.sigma, self.events.after(t0), t0, run=self))

    def tables(self) -> dict:
        """The tables of the run directory: {file name: columns}."""
        ev = self.events
        t0 = self.friction.friction.t_transient
        out = {EVENTS: {"t_max": ev.t_max, "t_min": ev.t_min,
                        "duration": ev.t_min - ev.t_max, "sigma_fail": ev.sigma_fail,
                        "drop": ev.drop, "late": (ev.t_max >= t0).astype(int),
                        "large": self.large.large.astype(int)}}
        if self.clusters is not None:
            out[EVENTS].update(self.clusters.events_table)
        if self.ledger is not None:
            out[EVENTS].update(catalogue.energy_rows(*self.ledger.ledger_rows(ev.i_max,
                                                                              ev.i_min)))
        if self.order is not None and not self.order.recorded:
            out[PSI] = {"t": self.order.t, "psi": self.order.psi}
        if self.clusters is not None:
            if not self.clusters.recorded:
                out[CLUSTERS] = self.clusters.table
        return out


def transient_time(spec: RunSpec, settings: AnalysisSettings, t_equil: float) -> float:
    """The end of the transient: the fixed fraction of the run (the same rule as the engine's
    and fix bk/slips's), or the detected equilibration time."""
    if settings.transient_rule == "detect" and math.isfinite(t_equil):
        return t_equil
    return transient_step(settings.transient, spec.n_steps) * spec.dt


def friction_result(spec: RunSpec, settings: AnalysisSettings, red: reduced.Reduced,
                    t, sigma, t_transient: float) -> FrictionResult:
    """mu_bar at the run's threshold and at the report thresholds (the slips from the run's
    extrema), the mean stress ratio (the block means ``t``, ``sigma`` weighted by their
    samples) and its error (batch means of the blocks)."""
    unit = spec.mu_s * spec.stress_unit
    weights = red.weights()

    def at(fraction):
        return stress.macroscopic_friction(t, sigma, spec.stress_unit, fraction * unit,
                                           t_transient=t_transient,
                                           events=red.events(fraction * unit), weights=weights)

    late = np.asarray(t, dtype=float) >= t_transient
    ratio_err = stationarity.mean_error(np.asarray(sigma, dtype=float)[late] / spec.stress_unit)
    scaled = settings.slip_threshold * min(1.0, SCALED_N / spec.N)
    reachable = red.raw is not None or (red.has_extrema and
                                        scaled * unit >= red.threshold * (1 - 1e-12))
    return FrictionResult(at(settings.slip_threshold),
                          {threshold_key(f): at(f) for f in settings.report_thresholds},
                          ratio_err.error,
                          scaled=at(scaled) if reachable else None)


def _phase(phase: dict | None) -> dict | None:
    """The phase series as states.window reads it (R as the modulus of Z where the series
    has no column R)."""
    if phase is None:
        return None
    if "R" not in phase:
        phase = {**phase, "R": np.hypot(phase["Z_re"], phase["Z_im"])}
    return phase


def run_window(spec: RunSpec, settings: AnalysisSettings, t, sigma, phase,
               t_transient: float, events: stress.SlipEvents | None = None,
               weights=None) -> states.Window:
    """The analysed window of one run (``bkflow.observables.states.window``)."""
    late = None if events is None else events.after(t_transient)
    return states.window(spec, t, sigma, _phase(phase), t_transient, settings.n_blocks,
                         settings.alpha, None if late is None else late.t_max,
                         None if late is None else late.sigma_fail, weights=weights)


def companion_result(spec: RunSpec, settings: AnalysisSettings, t_transient: float,
                     mean_stress_ratio: float, red: reduced.Reduced) -> CompanionResult:
    """The companion's window over the main run's [t_transient, end], and the gap."""
    comp = spec.companion_spec
    w = run_window(comp, settings, *red.series(), t_transient, weights=red.weights())
    gap = mean_stress_ratio / w.mean - 1 if w.mean else math.nan
    return CompanionResult(comp.start, w, gap)


def state_result(window: states.Window, companion: CompanionResult | None = None,
                 both: states.Window | None = None) -> StateResult:
    """The run's verdict, or with a companion the pair's (``pair.pair_verdict``; ``both``:
    the window of the pair's mean stress)."""
    if companion is None:
        return StateResult(window.state, window)
    disagree = pair.pair_disagrees(window, companion.window, STEADY_AGREEMENT)
    return StateResult(pair.pair_verdict(window.state, companion.state, both, disagree),
                       window, companion)


def pair_window(spec: RunSpec, settings: AnalysisSettings, red: reduced.Reduced,
                companion: reduced.Reduced, t_transient: float) -> states.Window | None:
    """The window of the pair's mean stress (the mean of the run's and its companion's block
    series, sample for sample), whose trend the pair's verdict tests; None where the two
    series are not of one length (a companion recorded otherwise)."""
    t, sigma, _ = red.series()
    tc, sc, _ = companion.series()
    if len(tc) != len(t) or not np.array_equal(red.weights(), companion.weights()):
        return None
    return run_window(spec, settings, t, 0.5 * (sigma + sc), None, t_transient,
                      weights=red.weights())


def large_drop_result(spec: RunSpec, settings: AnalysisSettings, events: stress.SlipEvents,
                      t_transient: float) -> LargeDropResult:
    late = events.t_max >= t_transient
    threshold = settings.large_drop_factor * float(np.mean(events.drop[late])) \
        if late.any() else math.nan
    large = late & (events.drop > threshold)
    return LargeDropResult(threshold, large,
                           stationarity.mean_error(events.sigma_fail[large] / spec.stress_unit))


def drop_result(settings: AnalysisSettings, late: stress.SlipEvents) -> DropResult:
    x_min = (None if settings.drop_x_min_over_threshold is None
             else settings.drop_x_min_over_threshold * late.threshold)
    return DropResult(stress.power_law_test(late.drop, x_min=x_min))


def order_result(spec: RunSpec, settings: AnalysisSettings, steps, positions) -> OrderResult:
    lat = square_lattice(spec.Lx, spec.Ly)
    shifts = order.lattice_shifts(lat.positions, lat.bonds, lat.box)
    ts = np.asarray(steps) * spec.dt
    p = order.psi(order.bond_vectors(positions, lat.bonds, shifts=shifts), lat.bonds, spec.N)
    return OrderResult(ts, p, order.psi_inf(ts, p, settings.psi_late_fraction))


def order_from_record(spec: RunSpec, settings: AnalysisSettings, steps, psi) -> OrderResult:
    """Psi(t) as the run computed it (fix bk/psi) and its plateau."""
    ts = np.asarray(steps) * spec.dt
    p = np.asarray(psi, float)
    return OrderResult(ts, p, order.psi_inf(ts, p, settings.psi_late_fraction), recorded=True)


def estimates(spec: RunSpec, settings: AnalysisSettings, fr: FrictionResult,
              large: LargeDropResult, comp: CompanionResult | None,
              companion: reduced.Reduced | None, t0: float):
    """The friction numbers a run reports, each covering the switching: with a companion
    that kept its slips, the pair's means (the steady protocol's estimate: its two starts
    approach the steady state from either side, pair.PairMean); and the length the error
    target would need (states.needed_length)."""
    if comp is not None and companion.has_extrema:
        cspec = spec.companion_spec
        cfr = friction_result(cspec, settings, companion, *companion.series()[:2], t0)
        cfr = cfr.covering(comp.window, cspec)
        fr = fr.paired(cfr)
        large = large.paired(large_drop_result(cspec, settings, cfr.friction.events,
                                               t0).covering(comp.window, cspec))
    if spec.target_error is not None and states.calibrated(spec) is None:
        mu = fr.pair["mu_bar"].value if fr.pair else fr.friction.mu_bar
        fr = dataclasses.replace(fr, t_needed=states.needed_length(spec, mu,
                                                                   2 if fr.pair else 1))
    return fr, large


def summarize(spec: RunSpec, red: reduced.Reduced, snapshots=None, slip_frames=None,
              settings: AnalysisSettings = AnalysisSettings(), companion=None,
              slip_breaks=None, psi=None, slip_rows=None) -> RunAnalysis:
    """The analysis of one run.

    ``red``: the run's records of its stress and phases (``bkflow.observables.reduced.Reduced``: the
    extrema and the block sums of fix bk/reduce, or ``reduced.from_series`` of a raw
    series); with the energy ledger when its scene kept it. ``companion``: the companion
    run's records (RunSpec.companion), or None. ``snapshots``: (steps (F,), unwrapped
    positions (F, N, 2)) of the order scene, or None. ``slip_frames``: (steps, positions) of
    fix bk/slips, frames in pairs (maximum, minimum), or None; ``slip_breaks`` (frames, N):
    their column of first breaks (fix bk/slips ``breaks``), or None. ``psi``: (steps, Psi) as
    the run computed it (fix bk/psi), or None; it takes the place of ``snapshots``.
    ``slip_rows``: (slips, clusters), the slips' rows the run computed (fix bk/slips
    ``catalogue``), or None; they take the place of ``slip_frames``.
    """
    settings = settings.resolved(spec)
    t, sigma, phase = red.series()
    t_equil = stationarity.equilibration_time(t, sigma)
    t0 = transient_time(spec, settings, t_equil)
    fr = friction_result(spec, settings, red, t, sigma, t0)
    events = fr.friction.events
    win = run_window(spec, settings, t, sigma, phase, t0, events, weights=red.weights())
    comp = None if companion is None else companion_result(
        spec, settings, t0, fr.friction.mean_stress_ratio, companion)
    both = None if companion is None else pair_window(spec, settings, red, companion, t0)
    # the trend the verdict read (its error widened by the layer's calibrated fluctuations;
    # with a companion, the pair's mean's), not a second test that the summary would report
    steady = StationarityResult((both or win).trend, t_equil)
    verdict = state_result(win, comp, both)
    fr, large = estimates(spec, settings, fr.covering(win, spec), large_drop_result(
        spec, settings, events, t0).covering(win, spec), comp, companion, t0)
    drops = drop_result(settings, events.after(t0))
    orders = order_from_record(spec, settings, *psi) if psi is not None else \
        None if snapshots is None else order_result(spec, settings, *snapshots)
    psi_inf = orders.psi_inf if orders is not None else math.nan
    clus = cluster_from_rows(spec, settings, events, t0, *slip_rows, psi_inf, large.large) \
        if slip_rows is not None else None if slip_frames is None else cluster_result(
            spec, settings, events, t0, *slip_frames, psi_inf, large.large, slip_breaks)
    return RunAnalysis(spec, settings, events, fr, steady, verdict, large, drops, orders, clus,
                       ledger=red if red.has_ledger else None, t=t, sigma=sigma)


def analyze(run_dir, settings: AnalysisSettings = AnalysisSettings()) -> dict:
    """Analyse a finished run directory: write summary.json, events.parquet (and
    clusters.csv where the run kept slip frames; psi.csv for a run directory with snapshots
    but no psi.npy); return the summary as written (None where not measured).

    The directory is a ``bkflow run`` output (meta.json) or a deck run standalone with
    ``lmp -in in.bk`` (params.json from ``bkflow deck``, finished when stress.csv reaches
    t_end)."""
    rd = RunDir(run_dir)
    if not rd.path.is_dir():
        raise FileNotFoundError(f"{rd.path} is not a directory")
    with rd.lock():  # a run still being written is busy, not unfinished
        return _analyze_locked(rd, settings)


def _analyze_locked(rd: RunDir, settings: AnalysisSettings) -> dict:
    rd.check_record_readable()  # unreadable is the file system's refusal, not "not run"
    # a continuation cut short (Ctrl-C, a full disk): the finished run it continued comes
    # back first, as the next bkflow run would bring it back
    for d in (rd, rd.companion()):
        if d.path.is_dir():
            d.undo_continuation()
    meta = _finished_meta(rd)
    spec = rd.spec()
    red = rd.read_reduced(spec)
    if rd.is_complete():
        _check_every_sample(rd, spec, red)
    try:
        res = summarize(spec, red, settings=settings, **_recorded_inputs(rd, spec))
    except reduced.ReducedError as exc:
        raise AnalysisError(f"{rd.path}: {exc}") from None
    summary = {**res.summary(), "wall_time_s": meta.get("wall_time_s"),
               "bytes_written": meta.get("bytes_written")}
    _check_bounds(rd, spec, summary)
    return rd.write_analysis(summary, res.tables())


#: the summary's stress ratios that the model bounds (``stress.physical_bound``)
BOUNDED = ("mu_bar", "mean_stress_ratio", "mu_bar_large", "mu_bar_run",
           "mean_stress_ratio_run", "companion_mu_bar", "companion_mean_stress_ratio")


def _check_bounds(rd: RunDir, spec: RunSpec, summary: dict) -> None:
    """AnalysisError, loudly, where a stress ratio of ``summary`` is above what the model's
    contacts can hold: nothing is written that no physics can give."""
    drag = spec.mass * spec.gamma * spec.V_d / spec.stress_unit
    for name in BOUNDED:
        value = summary.get(name)
        why = None if not isinstance(value, (int, float)) else stress.bound_problem(
            name, float(value), spec.mu_s, drag)
        if why is not None:
            raise AnalysisError(f"{rd.path}: {why}: the analysis is wrong for these "
                                "parameters; nothing was written (please report it, with the "
                                "command that made the run)")


def _finished_meta(rd: RunDir) -> dict:
    """The run's meta.json, checked whole; {} for a deck run standalone (``lmp -in``), checked
    finished and run from the decks bkflow wrote. AnalysisError or DamagedRunError saying why
    the run cannot be analysed otherwise."""
    meta = rd.meta() if rd.is_complete() else None
    if meta is not None:
        why = rd.problem()  # every file as large as the run left it
        if why is not None:
            raise DamagedRunError(f"{rd.path}: {why}: {rd.damage_advice()}")
        return meta
    _check_decks_unchanged(rd)
    why = rd.finished_standalone()
    if why is not None:
        raise AnalysisError(why)
    return {}


def _check_decks_unchanged(rd: RunDir) -> None:
    """A standalone run's deck and params.json as bkflow deck wrote them. Which of the two
    was changed decides the advice: an edited deck ran something its params.json does not
    describe; an intact deck with another params.json ran what the deck says."""
    from bkflow.lammps.deckfiles import SIGNATURE, written_by_bkflow

    deck = rd.file(DECK)
    try:
        signed = SIGNATURE in formats.read_text(deck, errors="replace")[-400:]
    except FileNotFoundError:
        signed = False
    if signed and not written_by_bkflow(deck):
        raise AnalysisError(f"{deck} was edited after bkflow deck wrote it, so {PARAMS} "
                            "need not describe the run it made, and bkflow analyses a "
                            f"run by its {PARAMS}: write the deck again with the change "
                            "(bkflow deck ... --set NAME=VALUE) and run that")
    if signed and not written_by_bkflow(rd.file(PARAMS)):
        raise AnalysisError(f"{rd.file(PARAMS)} is not the one bkflow deck wrote "
                            f"beside {deck.name} (its digest on the deck's last line does "
                            "not match): the run was made with the deck's parameters; "
                            f"restore {PARAMS}, or write the deck again")


def _check_every_sample(rd: RunDir, spec: RunSpec, red: reduced.Reduced) -> None:
    """A finished run's records hold every sample of its steps (DamagedRunError if not)."""
    last = spec.n_steps // spec.stress_nevery * spec.stress_nevery
    if red.n_samples != last // spec.stress_nevery + 1 or \
            len(red.blocks) != last // spec.block_nevery + 1:
        raise DamagedRunError(f"{rd.path}: its records ({EXTREMA}, {BLOCKS}) hold "
                              f"{red.n_samples} samples in {len(red.blocks)} blocks, not the "
                              f"run's {last // spec.stress_nevery + 1}: the run is "
                              "damaged; run it again (bkflow run --overwrite, or the sweep "
                              "redoes it)")


def _recorded_inputs(rd: RunDir, spec: RunSpec) -> dict:
    """What the run's scene recorded besides its stress, as ``summarize``'s arguments."""
    out = {"snapshots": None, "slip_frames": None, "slip_breaks": None, "psi": None,
           "slip_rows": None, "companion": None}
    if spec.writes_snapshots:
        out["psi"] = rd.read_psi_record(spec)
        if out["psi"] is None:   # a run directory without psi.npy: Psi from its snapshots
            f = rd.read_snapshots(spec.N)
            out["snapshots"] = (f.steps, f.positions)
    if spec.writes_slips and spec.writes_slip_frames:
        f = rd.read_slip_frames(spec.N)
        out["slip_frames"], out["slip_breaks"] = (f.steps, f.positions), f.breaks
    elif spec.writes_slips:
        out["slip_rows"] = rd.read_slip_rows(spec)
    if spec.companion is not None:
        out["companion"] = rd.companion().read_reduced(spec.companion_spec)
    return out
