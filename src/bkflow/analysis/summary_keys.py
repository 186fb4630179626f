"""Every key of a run's summary, declared once with the observable that computes it: its unit,
meaning, the value it holds where the run did not measure it, and whether the sweep's results
average it over seeds.

Every observable, bkflow's own and an added one alike, gives its keys through one path: its
``compute(ctx)`` takes a ``Context`` (the run's parameters and settings, its analysed stress
series, the slips after the transient, and the run's results of bkflow's own observables,
``bkflow.analysis.summary.RunAnalysis``) and returns {key: value} for exactly its declared
keys, or None where the run did not record what it needs (its keys then hold their
``missing`` values). ``summary(ctx)`` is the summary in the order the keys are declared.

The consumers read these declarations rather than lists of their own: results.csv averages
the ``averaged`` keys (``averaged_keys``, in the order of ``COLUMNS`` and then of their
declaration), the power-law verdicts are read by their declared names (``power_law_keys``),
docs/analysis.md's table of keys is rendered from it (``keys_table``), and an observable added
by the recipe of docs/develop.md ("Adding an observable") is computed, printed, tabled and
drawn from its declaration alone (``compute``, ``line``, ``figure``).

An observable's declaration::

    Observable("mean_drop", keys=(Key("mean_drop", "sigma_n", "the mean stress drop ...",
                                      averaged=True),),
               compute=my_function, line="mean stress drop {mean_drop:.4g} sigma_n",
               figure="mean_drop")
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from bkflow import __version__
from bkflow.model.scenes import RECORDS, records
from bkflow.observables import catalogue

NAN = math.nan


@dataclass(frozen=True)
class Key:
    """One key of a run's summary."""

    name: str
    unit: str          # "sigma_n": a stress ratio; "stress", "time", "l" (lattice spacing),
    #                    "" (a pure number), "label" (a word), "count", "bool", "map" (by key)
    meaning: str
    missing: object = NAN   # its value where the run did not measure it
    #: results.csv gives its mean over the seeds with a standard error (its column: ``COLUMNS``)
    averaged: bool = False


@dataclass(frozen=True)
class Context:
    """What an observable's ``compute`` gets: the run (``spec``, ``settings`` resolved for it),
    its analysed stress series (``t``, ``sigma``, sigma_x in stress units), the slips after the
    transient (``events``: bkflow.observables.stress.SlipEvents), the transient's end
    ``t_transient``, and ``run``: the results of bkflow's own observables
    (``bkflow.analysis.summary.RunAnalysis``), which their ``compute`` reads."""

    spec: object
    settings: object
    t: object
    sigma: object
    events: object
    t_transient: float
    run: object


@dataclass(frozen=True)
class Observable:
    """An observable and its summary keys. ``needs``: the record without which its keys hold
    their ``missing`` values (a name of ``bkflow.model.scenes.RECORDS``: the scenes that keep
    it say where it is measured; None: every run has it).
    ``compute``: Context -> {key: value} of exactly its keys, or None where the run did not
    record what it needs. ``written_by``: instead of ``compute``, the part of bkflow that writes
    the keys into the summary (the run's record: its files, its wall time).
    ``line``: the line ``bkflow run`` and ``bkflow analyze`` print, a format string of its keys.
    ``figure``: the key ``bkflow plot`` draws against phi, one series per size (figure
    ``fig_<key>``)."""

    name: str
    keys: tuple[Key, ...]
    needs: str | None = None
    compute: Callable | None = field(default=None, compare=False)
    line: str | None = None
    figure: str | None = None
    written_by: str | None = None

    def __post_init__(self):
        if self.needs is not None and self.needs not in RECORDS:
            raise ValueError(f"observable {self.name!r} needs {self.needs!r}, not a record a "
                             f"scene keeps ({', '.join(RECORDS)})")
        if (self.compute is None) == (self.written_by is None):
            raise ValueError(f"observable {self.name!r}: declare how its keys are found, "
                             "either compute or written_by (not both)")

    def values(self, ctx: Context) -> dict:
        """{key: value} of this observable for one run, in the order of its declaration: what
        ``compute`` gives, checked against the declared keys, or their ``missing`` values."""
        got = self.compute(ctx)
        if got is None:
            return {k.name: k.missing for k in self.keys}
        if not isinstance(got, dict):
            raise TypeError(f"observable {self.name}'s compute returned a "
                            f"{type(got).__name__}, not {{key: value}} of its keys "
                            f"{list(self.names)} (or None: not measured)")
        if set(got) != set(self.names):
            raise ValueError(f"observable {self.name} returned {sorted(got)}, not its declared "
                             f"keys {list(self.names)}")
        return {n: got[n] for n in self.names}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(k.name for k in self.keys)


def power_law_keys(prefix: str, what: str, ks: bool = True) -> tuple[Key, ...]:
    """The keys of a power-law test of ``what`` (the fit, its plausibility, the lognormal
    against it; bkflow.observables.stress.power_law_test), named ``<prefix>_...``."""
    keys = [Key(f"{prefix}_exponent", "", f"the maximum-likelihood exponent of the {what} "
                "above x_min (Clauset, Shalizi, Newman 2009, Eq. 3.1)",
                averaged=prefix == "drop"),
            Key(f"{prefix}_exponent_err", "", "its error, (alpha - 1)/sqrt(n_tail)"),
            Key(f"{prefix}_x_min", "stress" if prefix == "drop" else "l",
                "the lower end of the fitted tail"),
            Key(f"{prefix}_n_tail", "count", "the slips in the fitted tail", missing=None)]
    if ks:
        keys.append(Key(f"{prefix}_ks", "", "the Kolmogorov-Smirnov distance of the fit"))
    keys += [Key(f"{prefix}_power_law", "label", "plausible, rejected (bootstrap p below 0.1) "
                 "or no fit", missing=None),
             Key(f"{prefix}_fit_p", "", "the bootstrap p-value of the fit"),
             Key(f"{prefix}_vs_lognormal", "", "the normalised log-likelihood ratio against a "
                 "lognormal over the same tail (< 0 favours the lognormal)"),
             Key(f"{prefix}_vs_lognormal_p", "", "its p-value")]
    return tuple(keys)


def _power_law_verdicts(prefix: str) -> tuple[str, str, str, str]:
    return (f"{prefix}_power_law", f"{prefix}_fit_p", f"{prefix}_vs_lognormal",
            f"{prefix}_vs_lognormal_p")


def _shape_keys(suffix: str, whose: str) -> tuple[Key, ...]:
    large = bool(suffix)
    return (Key(f"lx_mean_over_Lx{suffix}", "", f"<l_x/Lx> over {whose}",
                averaged=not large),
            Key(f"ly_mean_over_Ly{suffix}", "", f"<l_y/Ly> over {whose}",
                averaged=not large),
            Key(f"lx_over_ly{suffix}", "", f"<l_x>/<l_y> over {whose}", averaged=True))


def _state_keys() -> tuple[Key, ...]:
    per_state = []
    for s in ("quiet", "coherent"):
        per_state += [Key(f"time_{s}", "", f"the fraction of the window's time spent {s}",
                          averaged=True),
                      Key(f"mean_stress_ratio_{s}", "sigma_n", f"<sigma_x>/sigma_n while {s}",
                          averaged=True),
                      Key(f"mu_bar_{s}", "sigma_n", f"mu_bar of the slips while {s}",
                          averaged=True)]
    return (
        Key("state", "label", "the verdict over the analysed window: steady, drifting, "
            "metastable, or the states visited (docs/model.md \"Steady state\")"),
        Key("state_evidence", "label", "pair (a run and its companion) or single run"),
        Key("state_own", "label", "the run's own verdict, without its companion"),
        Key("contacts_recorded", "bool", "whether the run recorded its contacts' phases"),
        Key("switching_calibrated", "bool", "whether the switching error is calibrated here"),
        Key("switching_not_calibrated_because", "label", "why not, or None"),
        Key("switching_error", "sigma_n", "the calibrated error of switching between states "
            "(where not calibrated, the one borrowed from the nearest calibrated layer, wider)"),
        Key("companion_start", "label", "the companion run's start (steady protocol)"),
        Key("companion_state", "label", "the companion's own state"),
        Key("companion_mean_stress_ratio", "sigma_n", "the companion's <sigma_x>/sigma_n"),
        Key("companion_mean_stress_ratio_err", "sigma_n", "its error"),
        Key("companion_gap", "", "this run's <sigma_x> / the companion's - 1"),
        Key("states_visited", "label", "the states the blocks of the window visited"),
        *per_state)


#: the contacts' phase statistics (bkflow.observables.phases); missing without a phase record
CONTACT_KEYS = (
    Key("phase_coherence", "", "the mean of R over the window", averaged=True),
    Key("phase_coherence_static", "", "|<Z>|"),
    Key("phase_fluctuation", "", "the phase fluctuation chi = N <|Z - <Z>|^2> (coherent "
        "above 3)", averaged=True),
    Key("phase_r2", "", "the second harmonic"),
    Key("phase_u_std", "", "the spread of u"),
    Key("phase_drift", "", "the trend of R"),
    Key("phase_drift_z", "", "its ratio to its error"),
    Key("contacts_coherent", "bool", "chi above the memory threshold", missing=None),
)


def _analysis(ctx: Context) -> dict:
    return {"bkflow": __version__, "params": ctx.spec.to_dict(),
            "settings": ctx.settings.to_dict()}


def _run(ctx: Context) -> dict:
    s = ctx.spec
    return {"N": s.N, "t_run": s.t_end, "dt": s.dt, "dt_rule": s.dt_rule}


def _result(name: str) -> Callable:
    """The ``compute`` of one of bkflow's own observables: the row of the run's result
    ``name`` (``RunAnalysis.<name>``: FrictionResult, ...; None where its scene did not record
    what it needs)."""
    def compute(ctx: Context) -> dict | None:
        part = getattr(ctx.run, name)
        return None if part is None else part.row()
    return compute


def _potency(ctx: Context) -> dict | None:
    clusters = ctx.run.clusters
    return None if clusters is None else clusters.potency_row()


def _energy(ctx: Context) -> dict | None:
    """The energy ledger's residual over the analysed run (the scenes that keep the ledger)."""
    ledger = ctx.run.ledger
    return None if ledger is None else {"energy_residual": catalogue.ledger_residual(
        ledger.ledger_at_blocks(), ctx.run.friction.friction.t_transient)}


OBSERVABLES: list[Observable] = [
    Observable("analysis", (
        Key("bkflow", "label", "the version of bkflow that analysed the run"),
        Key("params", "map", "the run's parameters (RunSpec)"),
        Key("settings", "map", "the analysis settings, resolved for the run"),
    ), compute=_analysis),
    Observable("record", (
        Key("analysis_revision", "count", "the revision of the analysis code"),
        Key("tables", "label", "the run's tables written beside the summary"),
        Key("table_files", "map", "their sizes and digests"),
        Key("wall_time_s", "time", "the run's wall-clock time in seconds"),
        Key("bytes_written", "count", "the bytes of the run's files"),
    ), written_by="the analysis as it writes the summary (bkflow.analysis.summary.analyze: "
                  "the run's wall time and bytes) and the store (bkflow.store.analysed: the "
                  "tables and the revision)"),
    Observable("run", (
        Key("N", "count", "the particles, Lx Ly"),
        Key("t_run", "time", "the length of the run", averaged=True),
        Key("dt", "time", "the time step"),
        Key("dt_rule", "label", "the rule the time step came from"),
    ), compute=_run),
    Observable("order", (Key("psi_inf", "", "the mean of Psi(t) over the last 20% of the run",
                             averaged=True),), needs="snapshots",
               compute=_result("order")),
    Observable("clusters", (
        *_shape_keys("", "all slip clusters (N_c >= 2)"),
        Key("n_clusters", "count", "the clusters", missing=None),
        Key("n_cluster_events", "count", "the slips whose frames were found", missing=None),
        Key("n_slips_without_snapshots", "count", "the slips without frames", missing=None),
        Key("regime", "label", "the most frequent of C, LC, DP, DT, W "
            "(bkflow.observables.clusters.regime)", missing=None),
        Key("regime_fractions", "map", "the share of each regime", missing=None),
        *_shape_keys("_large", "the clusters of the large slips"),
        Key("n_clusters_large", "count", "the clusters of the large slips", missing=None),
        Key("regime_large", "label", "their most frequent regime", missing=None),
        Key("regime_fractions_large", "map", "the share of each regime", missing=None),
    ), needs="slips", compute=_result("clusters")),
    Observable("potency", power_law_keys("potency", "slips' potencies", ks=False),
               needs="slips", compute=_potency),
    Observable("energy", (Key("energy_residual", "", "(plate work - change of energy - "
                              "dissipation) / plate work over the analysed run"),),
               needs="energy", compute=_energy),
    Observable("friction", (
        Key("mu_bar", "sigma_n", "<sigma_fail>/sigma_n over the slips after the transient",
            averaged=True),
        Key("mu_bar_err", "sigma_n", "its error, covering the switching between states"),
        Key("mu_bar_err_run", "sigma_n", "its error from the run's own correlated slips"),
        Key("mu_bar_err_reliable", "bool", "at least 10 effectively independent slips"),
        Key("n_slips", "count", "the slips after the transient", averaged=True),
        Key("mean_stress_ratio", "sigma_n", "the time average of sigma_x/sigma_n after the "
            "transient", averaged=True),
        Key("mean_stress_ratio_err", "sigma_n", "its error, covering the switching"),
        Key("mean_stress_ratio_err_run", "sigma_n", "its error over its correlated samples"),
        Key("slip_threshold_stress", "stress", "the slip threshold"),
        Key("t_transient", "time", "the transient's end"),
        Key("mu_bar_by_threshold", "map", "mu_bar at each report threshold (fraction of "
            "mu_s sigma_n)"),
        Key("mu_bar_scaled", "sigma_n", "mu_bar at the size-scaled threshold"),
        Key("slip_threshold_scaled", "stress", "the size-scaled threshold"),
        Key("mu_bar_err_by_threshold", "map", "their errors"),
        Key("n_slips_by_threshold", "map", "their slips"),
        Key("estimate", "label", "what the friction numbers are: pair (the mean of the run "
            "and its companion from the other start, the steady protocol's) or run (the run "
            "alone)"),
        Key("mu_bar_run", "sigma_n", "the run's own mu_bar (without its companion)"),
        Key("mean_stress_ratio_run", "sigma_n", "the run's own <sigma_x>/sigma_n"),
        Key("companion_mu_bar", "sigma_n", "the companion's mu_bar"),
        Key("mu_bar_bracket", "sigma_n", "half the pair's difference of mu_bar: how far their "
            "mean can lie from the long-run mean while the starts are remembered (the error "
            "is at least this)"),
        Key("mean_stress_ratio_bracket", "sigma_n", "the same of <sigma_x>/sigma_n"),
        Key("t_needed", "time", "the run length at which the calibrated error of mu_bar "
            "reaches the run's target (None: no target, no calibration, or reached sooner)",
            missing=None),
    ), compute=_result("friction")),
    Observable("stationarity", (
        Key("stationary", "bool", "the stress is trend-free over the window"),
        Key("drift", "", "the relative change of the stress across the window",
            averaged=True),
        Key("drift_err", "", "its standard error"),
        Key("drift_z", "", "its ratio to its error"),
        Key("drift_p", "", "its p-value"),
        Key("drift_bound", "", "the drift the test can resolve"),
        Key("block_t", "time", "the block means' times"),
        Key("block_means", "stress", "the block means the test rests on"),
        Key("t_equil", "time", "where the stationary part starts (equilibration detection)",
            averaged=True),
    ), compute=_result("steady")),
    Observable("state", _state_keys() + CONTACT_KEYS, compute=_result("state")),
    Observable("large", (
        Key("mu_bar_large", "sigma_n", "mu_bar over the slips whose drop exceeds the run's "
            "mean drop", averaged=True),
        Key("mu_bar_large_err", "sigma_n", "its error, covering the switching"),
        Key("mu_bar_large_err_run", "sigma_n", "its error from the run alone"),
        Key("n_slips_large", "count", "the large slips", averaged=True),
        Key("large_drop_threshold", "stress", "the drop that counts as large"),
    ), compute=_result("large")),
    Observable("drops", power_law_keys("drop", "stress drops"), compute=_result("drops")),
]

#: the order of results.csv's averaged columns of bkflow's own keys (those declared
#: ``averaged``): the friction first, as results.csv has always had them
COLUMNS = ("mu_bar", "mu_bar_large", "mean_stress_ratio", "psi_inf", "lx_over_ly",
           "lx_over_ly_large", "lx_mean_over_Lx", "ly_mean_over_Ly", "drop_exponent", "n_slips",
           "n_slips_large", "drift", "t_equil", "t_run", "phase_coherence", "phase_fluctuation",
           "time_quiet", "time_coherent", "mean_stress_ratio_quiet",
           "mean_stress_ratio_coherent", "mu_bar_quiet", "mu_bar_coherent")

#: the averaged keys that carry each run's own error (``<key>_err``, covering the switching)
WITHIN_RUN_ERRORS = ("mu_bar", "mu_bar_large", "mean_stress_ratio")


def keys() -> dict[str, Key]:
    """Every declared key by name."""
    return {k.name: k for o in OBSERVABLES for k in o.keys}


def observable(name: str) -> Observable:
    return next(o for o in OBSERVABLES if o.name == name)


def averaged_keys() -> tuple[str, ...]:
    """The keys results.csv averages over seeds: bkflow's own in their columns' order
    (``COLUMNS``), then those of added observables in the order they were declared."""
    declared = [k.name for o in OBSERVABLES for k in o.keys if k.averaged]
    return tuple(n for n in COLUMNS if n in declared) + tuple(n for n in declared
                                                               if n not in COLUMNS)


def summary(ctx: Context) -> dict:
    """A run's summary: the keys of every observable it computes (``compute``), in the order
    they are declared, each checked against its declaration; an observable that needs a
    record the run's scene does not keep is not computed: its keys hold their missing
    values."""
    row = {}
    for o in OBSERVABLES:
        if o.written_by is not None:
            continue
        if o.needs is not None and not records(ctx.spec.scene, o.needs):
            row.update((k.name, k.missing) for k in o.keys)
        else:
            row.update(o.values(ctx))
    return row


def lines(summary: dict) -> list[str]:
    """The printed lines of the added observables a summary holds."""
    return [o.line.format(**{n: summary[n] for n in o.names}) for o in OBSERVABLES
            if o.line is not None and all(summary.get(n) is not None for n in o.names)]


def figures() -> dict[str, str]:
    """{figure name: the key it draws against phi} of the observables that declare one."""
    return {f"fig_{o.figure}": o.figure for o in OBSERVABLES if o.figure is not None}


def power_law_names(prefix: str) -> tuple[str, str, str, str]:
    """The names of a power-law test's verdict, bootstrap p, lognormal ratio and its p."""
    names = _power_law_verdicts(prefix)
    missing = [n for n in names if n not in keys()]
    if missing:
        raise KeyError(f"no power-law test {prefix!r} is declared ({missing})")
    return names


def keys_table() -> str:
    """docs/analysis.md's table of the summary's keys (Markdown), one row per key."""
    rows = ["| key | observable | unit | meaning |", "|---|---|---|---|"]
    for o in OBSERVABLES:
        for k in o.keys:
            rows.append(f"| `{k.name}` | {o.name} | {k.unit} | {k.meaning} |")
    return "\n".join(rows)
