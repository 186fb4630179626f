"""One run's outputs turned into its summary: mu_bar, stress drops, Psi(inf), cluster shapes.

``summarize`` is pure: arrays in, a ``RunAnalysis`` out, made of one frozen result
per observable (``FrictionResult``, ``DropResult``, ``OrderResult``,
``ClusterResult``) and the tables the figures read (events, Psi(t), clusters).
``analyze`` reads a run directory through ``bkflow.store.rundir`` and writes the summary and
the tables back there. The observables are those of docs/model.md ("Observables"); the choices it
leaves open are one ``bkflow.model.params.AnalysisSettings``, recorded (resolved for the run)
in every summary, so that a summary made under other settings is known to be stale.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from bkflow import __version__
from bkflow.analysis import registry
from bkflow.model.lattice import square_lattice
from bkflow.model.params import (
    S_X,
    SCALED_N,
    STEADY_AGREEMENT,
    AnalysisSettings,
    RunSpec,
    transient_step,
)
from bkflow.observables import (
    catalogue,
    clusters,
    order,
    phases,
    reduced,
    states,
    stationarity,
    stress,
)
from bkflow.store import formats
from bkflow.store.rundir import (  # noqa: F401
    BLOCKS,
    CLUSTERS,
    DECK,
    EVENTS,
    EXTREMA,
    PARAMS,
    PSI,
    SLIPS,
    AnalysisError,
    DamagedRunError,
    RunDir,
)


def _key(fraction: float) -> str:
    return f"{fraction:g}"


@dataclass(frozen=True)
class FrictionResult:
    """mu_bar over the slips after the transient with its standard error, the time-averaged
    stress ratio with its standard error over the correlated samples (threshold-free: once,
    not per threshold), and mu_bar at each of the report thresholds (docs/model.md
    "Macroscopic friction"). The errors are the run's own (``..._err_run``) until
    ``covering`` widens them to cover the layer's switching between states
    (``bkflow.observables.states``): each is then an error of the layer's long-run mean."""

    friction: stress.MacroscopicFriction
    by_threshold: dict  # fraction of mu_s sigma_n -> MacroscopicFriction
    mean_stress_ratio_err: float
    #: at the size-scaled threshold (params.SCALED_N), None where the records do not reach it
    scaled: stress.MacroscopicFriction | None = None
    mean_stress_ratio_err_run: float = math.nan
    mu_bar_err: float = math.nan
    mu_bar_err_by_threshold: dict = field(default_factory=dict)

    def covering(self, window: states.Window, spec: RunSpec) -> FrictionResult:
        f = self.friction

        def cover(value, own):
            return window.err_of("mu_bar", value, own, spec.phi, spec.N)

        return dataclasses.replace(
            self, mean_stress_ratio_err=window.err,
            mean_stress_ratio_err_run=self.mean_stress_ratio_err,
            mu_bar_err=cover(f.mu_bar, f.mu_bar_err),
            mu_bar_err_by_threshold={k: cover(v.mu_bar, v.mu_bar_err)
                                     for k, v in self.by_threshold.items()})

    def row(self) -> dict:
        f = self.friction
        covered = bool(self.mu_bar_err_by_threshold)
        return {"mu_bar": f.mu_bar, "mu_bar_err": self.mu_bar_err if covered else f.mu_bar_err,
                "mu_bar_err_run": f.mu_bar_err,
                "mu_bar_err_reliable": f.error_reliable, "n_slips": f.n_slips,
                "mean_stress_ratio": f.mean_stress_ratio,
                "mean_stress_ratio_err": self.mean_stress_ratio_err,
                "mean_stress_ratio_err_run": (self.mean_stress_ratio_err_run if covered
                                              else self.mean_stress_ratio_err),
                "slip_threshold_stress": f.threshold,
                "t_transient": f.t_transient,
                "mu_bar_by_threshold": {k: v.mu_bar for k, v in self.by_threshold.items()},
                "mu_bar_scaled": self.scaled.mu_bar if self.scaled is not None else math.nan,
                "slip_threshold_scaled": (self.scaled.threshold if self.scaled is not None
                                          else math.nan),
                "mu_bar_err_by_threshold": (dict(self.mu_bar_err_by_threshold) if covered else
                                            {k: v.mu_bar_err
                                             for k, v in self.by_threshold.items()}),
                "n_slips_by_threshold": {k: v.n_slips for k, v in self.by_threshold.items()}}


@dataclass(frozen=True)
class LargeDropResult:
    """mu_bar over the run's large drops only (docs/model.md "Macroscopic friction", the relative
    reading): slips after the transient whose drop exceeds ``factor`` times the mean drop of
    those slips. The paper averages sigma_fail "right before large stress drops" and never says
    what large is; the run's own mean drop needs no scale and adapts to every phi: a stiff
    layer's bimodal drops (small reloading drops, system-wide ones) are split between the
    modes, and of a broad distribution its upper part is kept. Its error covers the switching
    as mu_bar's does (``covering``: the calibration of mu_bar at the 1% threshold)."""

    threshold: float          # the drop that counts as large (stress units)
    large: np.ndarray         # per event (all events): large or not
    estimate: stationarity.MeanEstimate
    err: float = math.nan

    def covering(self, window: states.Window, spec: RunSpec) -> LargeDropResult:
        e = self.estimate
        return dataclasses.replace(self, err=window.err_of("mu_bar", e.mean, e.error, spec.phi,
                                                           spec.N))

    def row(self) -> dict:
        e = self.estimate
        return {"mu_bar_large": e.mean,
                "mu_bar_large_err": self.err if math.isfinite(self.err) else e.error,
                "mu_bar_large_err_run": e.error,
                "n_slips_large": e.n, "large_drop_threshold": self.threshold}


@dataclass(frozen=True)
class StationarityResult:
    """The trend test of the stress over the analysed window, and the detected transient."""

    test: stationarity.Stationarity
    t_equil: float

    def row(self) -> dict:
        s = self.test
        return {"stationary": s.stationary, "drift": s.drift, "drift_err": s.drift_err,
                "drift_z": s.drift_z, "drift_p": s.p_value, "drift_bound": s.drift_bound,
                "block_t": s.block_t.tolist(), "block_means": s.block_means.tolist(),
                "t_equil": self.t_equil}


@dataclass(frozen=True)
class CompanionResult:
    """The companion run over the same window (RunSpec.companion): its own window (state,
    mean stress, errors; ``bkflow.observables.states.Window``) and the gap main / companion - 1 of
    the two mean stresses."""

    start: str
    window: states.Window
    gap: float

    @property
    def state(self) -> str:
        return self.window.state

    @property
    def mean_stress_ratio(self) -> float:
        return self.window.mean


def pair_state(main: str, other: str, disagree: bool) -> str:
    """The verdict of a run and its companion (``bkflow.observables.states.VERDICTS``): metastable
    when either is, or their means disagree beyond both errors; the states either visited where
    either names its states; drifting when either drifts; steady when both are."""
    if disagree or "metastable" in (main, other):
        return "metastable"
    if main in states.SWITCHING or other in states.SWITCHING:
        seen = {s for v in (main, other) if v in states.SWITCHING for s in v.split("+")}
        return "+".join(s for s in states.STATE_NAMES if s in seen)
    return "drifting" if "drifting" in (main, other) else "steady"


@dataclass(frozen=True)
class StateResult:
    """The state of the run over its analysed window (docs/model.md "Steady state",
    ``bkflow.observables.states.VERDICTS``): steady, drifting, metastable, or the states it visited
    where the layer switches between states more slowly than the window averages over them, from the
    stress's trend test, the contacts' phases (``contacts`` None for a run made before bkflow
    recorded them) and the calibrated switching (``bkflow.observables.states``); with a companion
    run, from the pair (``pair_state``)."""

    state: str
    window: states.Window
    companion: CompanionResult | None = None

    @property
    def contacts(self) -> phases.Coherence | None:
        return self.window.contacts

    def row(self) -> dict:
        c, k, w = self.contacts, self.companion, self.window
        row = {"state": self.state, "state_evidence": "pair" if k is not None else "single run",
               "state_own": w.state, "contacts_recorded": c is not None,
               "switching_calibrated": w.calibration is None,
               "switching_not_calibrated_because": w.calibration,
               "switching_error": (math.sqrt(w.var_switching) * abs(w.mean)
                                   if w.var_switching is not None else math.nan),
               "companion_start": None if k is None else k.start,
               "companion_state": None if k is None else k.state,
               "companion_mean_stress_ratio": math.nan if k is None else k.mean_stress_ratio,
               "companion_mean_stress_ratio_err": math.nan if k is None else k.window.err,
               "companion_gap": math.nan if k is None else k.gap}
        row.update((w.comp or states.Composition({}, {}, {})).row())
        if w.comp is None:
            row["states_visited"] = None
        if c is None:
            return {**row, **{k.name: k.missing for k in registry.CONTACT_KEYS}}
        return {**row, "phase_coherence": c.R, "phase_coherence_static": c.R_static,
                "phase_fluctuation": c.fluctuation, "phase_r2": c.R2, "phase_u_std": c.u_std,
                "phase_drift": c.trend.drift, "phase_drift_z": c.trend.drift_z,
                "contacts_coherent": bool(c.fluctuation > states.memory_chi(w.n))}


@dataclass(frozen=True)
class DropResult:
    """The power law of stress-drop sizes after the transient, and whether it is plausible at
    all (Clauset et al. 2009: the fit, its bootstrap p-value, the test against a lognormal)."""

    test: stress.PowerLawTest

    @property
    def fit(self) -> stress.PowerLawFit:
        return self.test.fit

    def row(self) -> dict:
        f, t = self.fit, self.test
        return {"drop_exponent": f.alpha, "drop_exponent_err": f.alpha_err,
                "drop_x_min": f.x_min, "drop_n_tail": f.n_tail, "drop_ks": f.ks,
                "drop_power_law": t.verdict, "drop_fit_p": t.p,
                "drop_vs_lognormal": t.lognormal_R, "drop_vs_lognormal_p": t.lognormal_p}


@dataclass(frozen=True)
class OrderResult:
    """Psi(t) and its plateau Psi(inf)."""

    t: np.ndarray
    psi: np.ndarray
    psi_inf: float
    # computed in the run (psi.npy, fix bk/psi): a record of the run, not a table to write
    recorded: bool = False

    def row(self) -> dict:
        return {"psi_inf": self.psi_inf}


@dataclass(frozen=True)
class ClusterResult:
    """Every cluster of the slips after the transient, their mean shape and the regime; the
    same for the clusters of the large slips only (keys ``..._large``)."""

    table: dict              # columns of clusters.csv
    shape: clusters.ClusterShape
    n_events: int            # slips whose frames were found
    n_without_snapshots: int
    shape_large: clusters.ClusterShape
    # the catalogue's columns of every event (NaN where a slip has no frames): the size and
    # shape (catalogue.SIZE_COLUMNS), and with the breaks recorded the nucleation and front
    events_table: dict = field(default_factory=dict)
    # the magnitude-frequency view: the power law of the potencies of the slips after the
    # transient (as the stress drops')
    potency: stress.PowerLawTest | None = None
    # the clusters' rows are the run's own (clusters.npy, fix bk/slips ``catalogue``): a
    # record of the run, not a table to write again
    recorded: bool = False

    def row(self) -> dict:
        s, g = self.shape, self.shape_large
        p = self.potency
        magnitude = {} if p is None else {
            "potency_exponent": p.fit.alpha, "potency_exponent_err": p.fit.alpha_err,
            "potency_x_min": p.fit.x_min, "potency_n_tail": p.fit.n_tail,
            "potency_power_law": p.verdict, "potency_fit_p": p.p,
            "potency_vs_lognormal": p.lognormal_R, "potency_vs_lognormal_p": p.lognormal_p}
        return {**magnitude,
                "lx_mean_over_Lx": s.lx_mean_over_Lx, "ly_mean_over_Ly": s.ly_mean_over_Ly,
                "lx_over_ly": s.lx_over_ly, "n_clusters": s.n_clusters,
                "n_cluster_events": self.n_events,
                "n_slips_without_snapshots": self.n_without_snapshots,
                "regime": s.regime, "regime_fractions": s.regime_fractions,
                "lx_mean_over_Lx_large": g.lx_mean_over_Lx,
                "ly_mean_over_Ly_large": g.ly_mean_over_Ly, "lx_over_ly_large": g.lx_over_ly,
                "n_clusters_large": g.n_clusters, "regime_large": g.regime,
                "regime_fractions_large": g.regime_fractions}


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
    extra: dict = field(default_factory=dict)
    # the records with the breaks and the energy ledger (scenes events, full), or None
    ledger: reduced.Reduced | None = None

    def summary(self) -> dict:
        """The summary row: parameters and settings nested, one key per observable."""
        row = {"bkflow": __version__, "params": self.spec.to_dict(),
               "settings": self.settings.to_dict(), "N": self.spec.N,
               "t_run": self.spec.t_end, "dt": self.spec.dt, "dt_rule": self.spec.dt_rule,
               **registry.not_measured()}
        for part in (self.friction, self.steady, self.state, self.large, self.drops, self.order,
                     self.clusters):
            if part is not None:
                row.update(part.row())
        if self.ledger is not None:
            row["energy_residual"] = catalogue.ledger_residual(
                self.ledger.ledger_at_blocks(), self.friction.friction.t_transient)
        row.update(self.extra)
        return row

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
    unit = spec.mu_s * spec.sigma_n
    weights = red.weights()

    def at(fraction):
        return stress.macroscopic_friction(t, sigma, spec.sigma_n, fraction * unit,
                                           t_transient=t_transient,
                                           events=red.events(fraction * unit), weights=weights)

    late = np.asarray(t, dtype=float) >= t_transient
    ratio_err = stationarity.mean_error(np.asarray(sigma, dtype=float)[late] / spec.sigma_n)
    scaled = settings.slip_threshold * min(1.0, SCALED_N / spec.N)
    reachable = red.raw is not None or (red.has_extrema and
                                        scaled * unit >= red.threshold * (1 - 1e-12))
    return FrictionResult(at(settings.slip_threshold),
                          {_key(f): at(f) for f in settings.report_thresholds}, ratio_err.error,
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


def state_result(window: states.Window,
                 companion: CompanionResult | None = None) -> StateResult:
    if companion is None:
        return StateResult(window.state, window)
    disagree = states.pair_disagrees(window, companion.window, STEADY_AGREEMENT)
    return StateResult(pair_state(window.state, companion.state, disagree), window, companion)


def large_drop_result(spec: RunSpec, settings: AnalysisSettings, events: stress.SlipEvents,
                      t_transient: float) -> LargeDropResult:
    late = events.t_max >= t_transient
    threshold = settings.large_drop_factor * float(np.mean(events.drop[late])) \
        if late.any() else math.nan
    large = late & (events.drop > threshold)
    return LargeDropResult(threshold, large,
                           stationarity.mean_error(events.sigma_fail[large] / spec.sigma_n))


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


def cluster_result(spec: RunSpec, settings: AnalysisSettings, events: stress.SlipEvents,
                   t_transient: float, steps, positions, psi_inf: float,
                   large=None, breaks=None) -> ClusterResult:
    """Clusters of every slip after the transient whose frames (maximum, minimum) fix
    bk/slips wrote; frames are matched to events by step. ``large`` (per event): which slips
    are large, for the shape of their clusters alone. ``breaks`` (frames, N): each contact's
    first break in the slip (fix bk/slips ``breaks``), for the nucleation site and the
    front's speed. Also the event catalogue's columns of those slips
    (bkflow.observables.catalogue)."""
    steps = np.asarray(steps)
    if len(steps) % 2:
        raise ValueError(f"slip snapshots come in pairs (maximum, minimum); got "
                         f"{len(steps)} frames: the file is truncated")
    lat = square_lattice(spec.Lx, spec.Ly)
    shifts = order.lattice_shifts(lat.positions, lat.bonds, lat.box)
    # events of stress.csv by step: sample k of stress.csv is step k * stress_nevery
    index = {int(i) * spec.stress_nevery: k for k, i in enumerate(events.i_max)}
    rows = {"event": [], "t": [], "n_c": [], "l_x": [], "l_y": [], "n_x": [], "n_y": [],
            "slip": [], "bond_change": [], "eq2_estimate": []}
    with_breaks = spec.writes_energy
    if with_breaks and breaks is None and len(steps):
        raise DamagedRunError(f"{SLIPS} has no column brk, which the scene writes: the file is "
                              "damaged; run the run again")
    columns = catalogue.SIZE_COLUMNS + (catalogue.BREAK_COLUMNS[1:] if with_breaks else ())
    table = {c: np.full(len(events), np.nan) for c in columns}
    pairs, evs = [], []   # the frame pairs that are slips of this analysis, and their events
    for k in range(0, len(steps), 2):
        ev = index.get(int(steps[k]))
        if ev is None or events.t_max[ev] < t_transient:
            continue
        if int(steps[k + 1]) != int(events.i_min[ev]) * spec.stress_nevery:
            # the recorded slip ends elsewhere (an analysis threshold other than the run's):
            # its frames are not this slip's
            continue
        if with_breaks:
            b = breaks[k + 1]
            if ((b != -1) & ((b <= steps[k]) | (b > steps[k + 1]))).any() or \
                    not np.isfinite(b).all():
                raise DamagedRunError(
                    f"{SLIPS}: a first break (column brk) outside its slip, steps "
                    f"{int(steps[k])}..{int(steps[k + 1])}: the file is damaged; run the run "
                    "again")
        pairs.append(k)
        evs.append(ev)
    matched = len(pairs)
    if matched:  # every slip at once (catalogue.slip_rows)
        k = np.asarray(pairs)
        slips_, per = catalogue.slip_rows(np.asarray(positions)[k], np.asarray(positions)[k + 1],
                                          lat, settings.s_x, spec.k_b, shifts)
        ev = np.asarray(evs)
        for c in catalogue.SIZE_COLUMNS:
            table[c][ev] = slips_[c]
        if with_breaks:
            for j, (kk, e) in enumerate(zip(pairs, evs)):
                found = catalogue.nucleation_and_front(breaks[kk + 1], lat.positions, lat.box,
                                                       spec.dt, slips_["slipping"][j])
                for c, v in zip(catalogue.BREAK_COLUMNS[1:], found):
                    table[c][e] = v
        at = per.pop("slip_index")
        rows["event"] = ev[at].tolist()
        rows["t"] = events.t_max[ev[at]].astype(float).tolist()
        for c in rows:
            if c not in ("event", "t"):
                rows[c] = np.asarray(per[c]).tolist()
    return _cluster_summary(spec, settings, events, t_transient, rows, table, matched, psi_inf,
                            large)


def _cluster_summary(spec: RunSpec, settings: AnalysisSettings, events: stress.SlipEvents,
                     t_transient: float, rows: dict, table: dict, matched: int,
                     psi_inf: float, large=None) -> ClusterResult:
    """The clusters' shape (all, and the large slips'), the potencies' power law, from the
    clusters' rows and the catalogue's columns of every event."""
    box = (float(spec.Lx), float(spec.Ly))
    shape = clusters.cluster_shape(rows["l_x"], rows["l_y"], box, psi_inf,
                                   settings.span_fraction, settings.psi_crystal)
    big = np.zeros(len(rows["event"]), bool) if large is None else \
        np.asarray(large, bool)[np.asarray(rows["event"], dtype=int)]
    shape_large = clusters.cluster_shape(np.asarray(rows["l_x"])[big],
                                         np.asarray(rows["l_y"])[big], box, psi_inf,
                                         settings.span_fraction, settings.psi_crystal)
    n_late = int(np.sum(events.t_max >= t_transient))
    potency = table["potency"][np.isfinite(table["potency"])]
    test = stress.power_law_test(potency[potency > 0])
    return ClusterResult(rows, shape, matched, n_late - matched, shape_large, table, test)


#: the clusters' columns of clusters.csv after event and t, as the run's rows name them
CLUSTER_ROW_COLUMNS = ("n_c", "l_x", "l_y", "n_x", "n_y", "slip", "bond_change",
                       "eq2_estimate")


def cluster_from_rows(spec: RunSpec, settings: AnalysisSettings, events: stress.SlipEvents,
                      t_transient: float, slip_rows, cluster_rows, psi_inf: float,
                      large=None) -> ClusterResult:
    """``cluster_result`` from what the run computed of each slip (fix bk/slips
    ``catalogue``, scene figures: slips.npy and clusters.npy, at s_x = S_X): rows matched
    to the events by the steps of their maximum and minimum, as frames are."""
    if settings.s_x != S_X:
        raise AnalysisError(f"the run computed its slips' clusters at s_x = {S_X:g} (scene "
                            f"figures); s_x = {settings.s_x:g} needs the positions at each "
                            "slip (scene clusters, events or full)")
    nevery = spec.stress_nevery
    ev_max = np.asarray(events.i_max, np.int64) * nevery   # increasing, as the slips come
    ev_min = np.asarray(events.i_min, np.int64) * nevery
    smax = np.asarray(slip_rows["step_max"], np.int64)
    smin = np.asarray(slip_rows["step_min"], np.int64)
    table = {c: np.full(len(events), np.nan) for c in catalogue.SIZE_COLUMNS}
    if len(events):
        at = np.minimum(np.searchsorted(ev_max, smax), len(events) - 1)
        # a row of another threshold than this analysis's matches no slip of its own
        ok = (ev_max[at] == smax) & (ev_min[at] == smin) & \
            (np.asarray(events.t_max)[at] >= t_transient)
    else:
        at, ok = np.zeros(len(smax), np.int64), np.zeros(len(smax), bool)
    for c in catalogue.SIZE_COLUMNS:
        table[c][at[ok]] = np.asarray(slip_rows[c], float)[ok]
    matched, first = np.unique(smax[ok], return_index=True)
    cstep = np.asarray(cluster_rows["step_max"], np.int64)
    keep = np.isin(cstep, matched)
    ev_of = at[ok][first][np.searchsorted(matched, cstep[keep])].astype(np.int64)
    rows = {"event": ev_of.tolist(), "t": events.t_max[ev_of].astype(float).tolist()}
    for c in CLUSTER_ROW_COLUMNS:
        rows[c] = np.asarray(cluster_rows[c][keep]).tolist()
    return dataclasses.replace(
        _cluster_summary(spec, settings, events, t_transient, rows, table, len(matched),
                         psi_inf, large), recorded=True)


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
    # the trend the verdict read (its error widened by the layer's calibrated fluctuations),
    # not a second test of the same window that the summary would report beside it
    steady = StationarityResult(win.trend, t_equil)
    comp = None if companion is None else companion_result(
        spec, settings, t0, fr.friction.mean_stress_ratio, companion)
    verdict = state_result(win, comp)
    fr = fr.covering(win, spec)
    large = large_drop_result(spec, settings, events, t0).covering(win, spec)
    drops = drop_result(settings, events.after(t0))
    orders = order_from_record(spec, settings, *psi) if psi is not None else \
        None if snapshots is None else order_result(spec, settings, *snapshots)
    psi_inf = orders.psi_inf if orders is not None else math.nan
    clus = cluster_from_rows(spec, settings, events, t0, *slip_rows, psi_inf, large.large) \
        if slip_rows is not None else None if slip_frames is None else cluster_result(
            spec, settings, events, t0, *slip_frames, psi_inf, large.large, slip_breaks)
    extra = registry.compute_added(registry.Context(spec, settings, t, sigma, events.after(t0),
                                                    t0)) if registry.added() else {}
    return RunAnalysis(spec, settings, events, fr, steady, verdict, large, drops, orders, clus,
                       extra, ledger=red if red.has_ledger else None)


def analyze(run_dir, settings: AnalysisSettings = AnalysisSettings()) -> dict:
    """Analyse a finished run directory: write summary.json, events.parquet (and
    clusters.csv where the run kept slip frames; psi.csv for a run of an older bkflow's
    snapshots); return the summary as written (None where not measured).

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
    meta = rd.meta() if rd.is_complete() else None
    if meta is None:
        from bkflow.lammps.deck import SIGNATURE, written_by_bkflow

        # which file was changed since bkflow deck wrote the pair decides the advice: an
        # edited deck ran something its params.json does not describe; an intact deck with
        # another params.json ran what the deck says
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
        why = rd.finished_standalone()
        if why is not None:
            raise AnalysisError(why)
        meta = {}
    else:
        why = rd.problem()  # every file as large as the run left it
        if why is not None:
            raise DamagedRunError(f"{rd.path}: {why}: the run is damaged; run it again "
                                  "(bkflow run --overwrite, or the sweep redoes it)")
    spec = rd.spec()
    red = rd.read_reduced(spec)
    if rd.is_complete():   # a finished run's records hold every sample of its steps
        last = spec.n_steps // spec.stress_nevery * spec.stress_nevery
        if red.n_samples != last // spec.stress_nevery + 1 or \
                len(red.blocks) != last // spec.block_nevery + 1:
            raise DamagedRunError(f"{rd.path}: its records ({EXTREMA}, {BLOCKS}) hold "
                                  f"{red.n_samples} samples in {len(red.blocks)} blocks, not the "
                                  f"run's {last // spec.stress_nevery + 1}: the run is "
                                  "damaged; run it again (bkflow run --overwrite, or the sweep "
                                  "redoes it)")
    snaps = slips = slip_breaks = None
    psi = rd.read_psi_record(spec) if spec.writes_snapshots else None
    if spec.writes_snapshots and psi is None:   # a run made before bkflow computed Psi in it
        f = rd.read_snapshots(spec.N)
        snaps = (f.steps, f.positions)
    slip_rows = None
    if spec.writes_slips and spec.writes_slip_frames:
        f = rd.read_slip_frames(spec.N)
        slips, slip_breaks = (f.steps, f.positions), f.breaks
    elif spec.writes_slips:
        slip_rows = rd.read_slip_rows()
    companion = None
    if spec.companion is not None:
        companion = rd.companion().read_reduced(spec.companion_spec)
    try:
        res = summarize(spec, red, snaps, slips, settings, companion, slip_breaks, psi,
                        slip_rows)
    except reduced.ReducedError as exc:
        raise AnalysisError(f"{rd.path}: {exc}") from None
    summary = {**res.summary(), "wall_time_s": meta.get("wall_time_s"),
               "bytes_written": meta.get("bytes_written")}
    return rd.write_analysis(summary, res.tables())
