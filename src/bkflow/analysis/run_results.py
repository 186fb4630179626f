"""One run's results, one frozen dataclass per observable, each with the row it gives the
summary (``row()``; its keys are declared in ``bkflow.analysis.summary_keys``): friction, large
drops, the trend test, the state (with the companion run), the power law of the drops, order
and the slip clusters. ``bkflow.analysis.summary`` computes them."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from bkflow.analysis import summary_keys
from bkflow.model.params import RunSpec
from bkflow.observables import (
    clusters,
    pair,
    phases,
    states,
    stationarity,
    stress,
)


def threshold_key(fraction: float) -> str:
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
    #: with a companion run that kept its slips (the steady protocol's pair): each number as
    #: the mean of the two runs (key -> bkflow.observables.pair.PairMean: "mu_bar",
    #: "mean_stress_ratio", "scaled" and each report threshold's key), the run's own beside it
    pair: dict = field(default_factory=dict)
    #: the run length at which the calibrated error of the estimate (the pair's mean, or the
    #: run's) reaches the run's target (bkflow.observables.states.needed_length), or None
    t_needed: float | None = None

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

    def paired(self, other: FrictionResult) -> FrictionResult:
        """This run's numbers and its companion's (``other``, both covering the switching)
        as the pair's means (``bkflow.observables.pair.pair_mean``): the estimate of the
        steady protocol, whose two starts approach the steady state from either side."""
        f, g = self.friction, other.friction
        means = {"mu_bar": pair.pair_mean(f.mu_bar, self.mu_bar_err, g.mu_bar,
                                           other.mu_bar_err),
                "mean_stress_ratio": pair.pair_mean(
                    f.mean_stress_ratio, self.mean_stress_ratio_err, g.mean_stress_ratio,
                    other.mean_stress_ratio_err)}
        for k, v in self.by_threshold.items():
            w = other.by_threshold.get(k)
            if w is not None:
                means[k] = pair.pair_mean(v.mu_bar, self.mu_bar_err_by_threshold.get(
                    k, v.mu_bar_err), w.mu_bar, other.mu_bar_err_by_threshold.get(
                    k, w.mu_bar_err))
        if self.scaled is not None and other.scaled is not None:
            means["scaled"] = pair.pair_mean(self.scaled.mu_bar, self.scaled.mu_bar_err,
                                              other.scaled.mu_bar, other.scaled.mu_bar_err)
        return dataclasses.replace(self, pair=means)

    def row(self) -> dict:
        f = self.friction
        covered = bool(self.mu_bar_err_by_threshold)
        row = {"mu_bar": f.mu_bar, "mu_bar_err": self.mu_bar_err if covered else f.mu_bar_err,
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
               "n_slips_by_threshold": {k: v.n_slips for k, v in self.by_threshold.items()},
               "estimate": "pair" if self.pair else "run",
               "mu_bar_run": f.mu_bar, "mean_stress_ratio_run": f.mean_stress_ratio,
               "companion_mu_bar": math.nan, "mu_bar_bracket": math.nan,
               "mean_stress_ratio_bracket": math.nan, "t_needed": self.t_needed}
        return self._paired_row(row) if self.pair else row

    def _paired_row(self, row: dict) -> dict:
        """``row`` with the pair's means in place of the run's own."""
        p = self.pair
        row.update(mu_bar=p["mu_bar"].value, mu_bar_err=p["mu_bar"].err,
                   companion_mu_bar=p["mu_bar"].b, mu_bar_bracket=p["mu_bar"].bracket,
                   mean_stress_ratio=p["mean_stress_ratio"].value,
                   mean_stress_ratio_err=p["mean_stress_ratio"].err,
                   mean_stress_ratio_bracket=p["mean_stress_ratio"].bracket)
        row["mu_bar_by_threshold"] = {k: (p[k].value if k in p else v)
                                      for k, v in row["mu_bar_by_threshold"].items()}
        row["mu_bar_err_by_threshold"] = {k: (p[k].err if k in p else v)
                                          for k, v in row["mu_bar_err_by_threshold"].items()}
        if "scaled" in p:
            row["mu_bar_scaled"] = p["scaled"].value
        return row


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
    #: the pair's mean with a companion that kept its slips (``FrictionResult.pair``)
    pair: pair.PairMean | None = None

    def covering(self, window: states.Window, spec: RunSpec) -> LargeDropResult:
        e = self.estimate
        return dataclasses.replace(self, err=window.err_of("mu_bar", e.mean, e.error, spec.phi,
                                                           spec.N))

    def paired(self, other: LargeDropResult) -> LargeDropResult:
        return dataclasses.replace(self, pair=pair.pair_mean(
            self.estimate.mean, self.err, other.estimate.mean, other.err))

    def row(self) -> dict:
        e, p = self.estimate, self.pair
        return {"mu_bar_large": e.mean if p is None else p.value,
                "mu_bar_large_err": (p.err if p is not None else
                                     self.err if math.isfinite(self.err) else e.error),
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


@dataclass(frozen=True)
class StateResult:
    """The state of the run over its analysed window (docs/model.md "Steady state",
    ``bkflow.observables.states.VERDICTS``): steady, drifting, metastable, or the states it visited
    where the layer switches between states more slowly than the window averages over them, from the
    stress's trend test, the contacts' phases (``contacts`` None for a run directory without
    a phase record) and the calibrated switching (``bkflow.observables.states``); with a companion
    run, from the pair (``bkflow.observables.pair.pair_verdict``)."""

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
               "switching_error": (math.sqrt(w.var_error) * abs(w.mean)
                                   if w.var_error is not None else math.nan),
               "companion_start": None if k is None else k.start,
               "companion_state": None if k is None else k.state,
               "companion_mean_stress_ratio": math.nan if k is None else k.mean_stress_ratio,
               "companion_mean_stress_ratio_err": math.nan if k is None else k.window.err,
               "companion_gap": math.nan if k is None else k.gap}
        row.update((w.comp or states.Composition({}, {}, {})).row())
        if w.comp is None:
            row["states_visited"] = None
        if c is None:
            return {**row, **{k.name: k.missing for k in summary_keys.CONTACT_KEYS}}
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

    def potency_row(self) -> dict | None:
        """The power law of the potencies (None: not tested)."""
        p = self.potency
        return None if p is None else {
            "potency_exponent": p.fit.alpha, "potency_exponent_err": p.fit.alpha_err,
            "potency_x_min": p.fit.x_min, "potency_n_tail": p.fit.n_tail,
            "potency_power_law": p.verdict, "potency_fit_p": p.p,
            "potency_vs_lognormal": p.lognormal_R, "potency_vs_lognormal_p": p.lognormal_p}

    def row(self) -> dict:
        s, g = self.shape, self.shape_large
        return {"lx_mean_over_Lx": s.lx_mean_over_Lx, "ly_mean_over_Ly": s.ly_mean_over_Ly,
                "lx_over_ly": s.lx_over_ly, "n_clusters": s.n_clusters,
                "n_cluster_events": self.n_events,
                "n_slips_without_snapshots": self.n_without_snapshots,
                "regime": s.regime, "regime_fractions": s.regime_fractions,
                "lx_mean_over_Lx_large": g.lx_mean_over_Lx,
                "ly_mean_over_Ly_large": g.ly_mean_over_Ly, "lx_over_ly_large": g.lx_over_ly,
                "n_clusters_large": g.n_clusters, "regime_large": g.regime,
                "regime_fractions_large": g.regime_fractions}
