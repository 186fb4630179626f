"""The stop rule of an adaptive run (RunSpec.target_error, RunSpec.until_steady) and the steps
at which it is checked: ``AdaptiveStop`` reads the run's records at each check and says
whether the run may stop; ``stop_now`` adds a companion run's verdict and the pair's
agreement; ``next_check`` and ``check_chunk`` space the checks. What the rule found at the
stop is data (``AdaptiveStop.record``, meta.json's ``adaptive``); ``bkflow.cli.report`` words
it.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from bkflow.model.params import (
    ADAPTIVE_CHUNK_T,
    ADAPTIVE_T_MIN,
    STEADY_AGREEMENT,
    STEADY_DRIFT_BOUND,
    STEADY_T_MIN,
    RunSpec,
    transient_step,
)
from bkflow.observables import pair, states
from bkflow.observables.stationarity import mean_error
from bkflow.observables.stress import Zigzag
from bkflow.store.rundir import RunDir

#: the version of the stop rule a run's record says it stopped under (meta.json's
#: ``adaptive``): a run stopped under another (bkflow before 0.6, where a switching layer
#: stopped on its own error and the checks' spacing followed the cap) is neither continued
#: nor taken as the answer to a request (bkflow.lammps.continuation)
RULE = 2


class AdaptiveStop:
    """One leg's side of the stop rule of an adaptive run (RunSpec.adaptive), checked between
    chunks once the run is long enough (ADAPTIVE_T_MIN; STEADY_T_MIN for a run until steady),
    over the analysed window of the run so far (the transient rule of a fixed run of that
    length). ``reached`` reads the leg's records (fix bk/reduce: the extrema and the block
    sums, ``bkflow.observables.reduced``), as the summary reads them, so that the summary of
    the finished run finds the very same slips, errors, trend and state, and says whether the
    leg alone may stop:

    - ``target_error`` (a run alone): mu_bar's error is below the target and reliable, the
      error that covers the layer's switching between states (``bkflow.observables.states``):
      a layer that switches runs on until the switching is averaged over, or to its cap;
    - ``until_steady``: the window is ``steady`` (``bkflow.observables.states.window``: no
      memory of the start shown, the stress trend-free, a drift above STEADY_DRIFT_BOUND
      excluded) or names the states of a layer that switches (its trend is the switching's).

    With a companion the pair decides (``stop_now``): the error target then applies to the
    pair's mean (``bkflow.observables.pair.pair_mean``), and the two legs must agree within
    it. What the last check found is ``last`` (a ``bkflow.observables.states.Window``) and the
    pair's numbers; ``record`` returns them as data (meta.json's ``adaptive``), and
    ``bkflow.cli.stops.stop_line`` words it."""

    def __init__(self, spec: RunSpec, run_dir: RunDir):
        self.spec, self.rd = spec, run_dir
        self.fail = np.array([])    # sigma_fail of the slips so far
        self.t_fail = np.array([])
        # the slips at the run's threshold, found once: the final extrema fed as they come
        # (the last record, the extremum under way, is fed to a copy at each check)
        self.zigzag = Zigzag(spec.slip_threshold_stress)
        self.fed, self.maxima = 0, []
        self.met, self.checks = False, 0
        self.last: states.Window | None = None
        self.estimate = None        # mu_bar over the slips after the transient (MeanEstimate)
        self.last_error = None      # its error at the last check, covering the switching
        self.mu_bar = None          # the value the rule judged (the pair's mean with a pair)
        self.state_ok = False       # the leg's state allows a stop (until_steady)
        self.companion_gap = None   # the pair's gap of mean stresses at the last check
        self.pair_disagrees = False
        self.pair_legs = 1          # 2 once the pair's mean is the estimate
        self.series = None          # (t, sigma, weights, t0) read at the last check
        self.has_slips = False      # the leg records its turning points (extrema.npy)
        self.both = None            # the window of the pair's mean stress (the main run's)
        self.pair_state = None      # the pair's verdict at the last check

    @property
    def last_mean(self) -> float:
        return self.last.mean if self.last is not None else math.nan

    def error(self, t_transient: float):
        """mu_bar's own error over the slips after ``t_transient`` found so far."""
        return mean_error(self.fail[self.t_fail >= t_transient] / self.spec.stress_unit)

    def _read_slips(self, red) -> None:
        if not (red.has_extrema and len(red.extrema)):
            return
        s = np.asarray(red.extrema["sigma"], float)
        final = len(s) - 1
        self.maxima += self.zigzag.feed(s[self.fed:final].tolist())[0]
        self.fed = final
        pending = copy.copy(self.zigzag).feed([s[final]])[0]
        at = np.asarray(self.maxima + pending, np.int64)
        self.fail = s[at]
        self.t_fail = red.sample_index()[at] * self.spec.stress_nevery * self.spec.dt

    def reached(self, step: int) -> bool:
        """Read the leg's records at ``step`` and say whether the leg alone may stop (False
        before the first check's length)."""
        spec = self.spec
        t_min = STEADY_T_MIN if spec.until_steady else ADAPTIVE_T_MIN
        self.last = None
        if step * spec.dt < min(t_min, spec.t_end):
            return False
        self.checks += 1
        red = self.rd.read_reduced(spec)
        self.has_slips = red.has_extrema
        self._read_slips(red)
        t, sigma, phase = red.series()
        t0 = transient_step(spec.transient, step) * spec.dt
        self.series = (t, sigma, red.weights(), t0)
        self.last = win = states.window(spec, t, sigma, phase if spec.until_steady else None,
                                        t0, own_error=False, weights=red.weights())
        self.estimate = est = self.error(t0)
        self.mu_bar = est.mean
        self.last_error = win.err_of("mu_bar", est.mean, est.error, spec.phi, spec.N) \
            if est.n >= 2 else None
        self.state_ok = not spec.until_steady or bool(
            win.state in states.SWITCHING
            or (win.state == "steady" and win.trend.drift_bound <= STEADY_DRIFT_BOUND))
        met = self.state_ok
        if spec.target_error is not None:
            met &= self.error_met(self.last_error, spec.target_error)
        self.met = met
        return met

    def leg(self) -> pair.Leg:
        """This leg at the last check, as the pair's rule reads it."""
        est = self.estimate
        return pair.Leg(self.last, est.mean if est is not None else math.nan,
                        _err(self.last_error),
                        bool(est is not None and est.n >= 2 and est.reliable))

    def error_met(self, err, target: float) -> bool:
        """Whether an error of mu_bar (this leg's, or its pair's) meets ``target``: finite,
        from a reliable estimate, and at most the target."""
        est = self.estimate
        return bool(est is not None and est.n >= 2 and est.reliable and err is not None
                    and math.isfinite(err) and err <= target)

    def record(self, requested: RunSpec, t_run: float, stopped_early: bool) -> dict:
        """What the stop rule found, as data (``bkflow.cli.stops.stop_line`` words it)."""
        w = self.last
        trend = _attr(self.both if self.both is not None else w, "trend")
        comp, contacts = _attr(w, "comp"), _attr(w, "contacts")
        mu = self.mu_bar if self.mu_bar is not None else math.nan
        needed = states.needed_length(requested, mu, self.pair_legs) \
            if requested.target_error is not None else None
        return {"rule": RULE, "target_error": requested.target_error,
                "until_steady": requested.until_steady,
                "drift_bound_required": STEADY_DRIFT_BOUND if requested.until_steady else None,
                "agreement_required": (pair_agreement(requested, mu)
                                       if requested.companion else None),
                "t_cap": requested.t_end, "t_run": t_run,
                "reached": bool(stopped_early or self.met),
                "estimate": "pair" if self.pair_legs == 2 else "run",
                "mu_bar_at_stop": self.mu_bar,
                "mu_bar_err_at_stop": self.last_error,
                "state_at_stop": self.pair_state if self.pair_state else _attr(w, "state"),
                "states_visited_at_stop": _attr(comp, "name"),
                "drift_at_stop": _attr(trend, "drift"),
                "drift_err_at_stop": _attr(trend, "drift_err"),
                "drift_z_at_stop": _attr(trend, "drift_z"),
                "drift_bound_at_stop": _attr(trend, "drift_bound"),
                "phase_fluctuation_at_stop": _attr(contacts, "fluctuation"),
                "memory_chi": states.memory_chi(requested.N),
                "companion_gap_at_stop": self.companion_gap,
                "pair_disagrees_at_stop": self.pair_disagrees,
                "switching_calibrated": None if w is None else w.calibration is None,
                "t_needed": needed,
                "advice": advice(requested, mu, self.pair_legs, t_run, needed, self.rd.path),
                "checks": self.checks}


def round_up(x: float, digits: int = 2) -> float:
    """``x`` rounded up to ``digits`` significant digits (a run length one can type)."""
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return float(f"{math.ceil(x / scale - 1e-9) * scale:.{digits}g}")


def advice(requested: RunSpec, mu_bar: float, legs: int, t_run: float,
           needed: float | None, out) -> dict | None:
    """What a run that has not reached its error target would need (None: it has, or the
    calibration of the switching does not reach it): the run length ``needed`` (from the
    calibration, ``bkflow.observables.states.needed_length``: the same for every run of the
    layer), rounded up, its cost in atom-steps, and whether one run of that length is within
    this machine's limits (``bkflow.lammps.limits``); where not, the longest that is and the
    error it would give."""
    from bkflow.lammps.limits import cost, longest_run, within_limits

    if needed is None or needed <= t_run:
        return None
    t_end = round_up(needed)
    longer = requested.replace(t_end=t_end)
    # what the continuation adds: the steps from where the run stopped
    more = cost(longer).atom_steps - cost(requested.replace(t_end=t_run)).atom_steps
    out_ = {"t_end": t_end, "atom_steps": more,
            "above_limits": within_limits(longer, out), "t_end_max": None,
            "err_at_max": None}
    if out_["above_limits"] is not None:
        top = longest_run(requested, out, t_end)
        if top is not None and top > t_run:
            var = states.window_variance("mu_bar", requested.phi, requested.N,
                                         top * (1 - requested.transient))
            out_["t_end_max"] = top
            out_["err_at_max"] = math.sqrt(var / legs) * mu_bar if var is not None else None
    return out_


def _attr(obj, name: str):
    """``obj.name``, or None where there is no ``obj``."""
    return None if obj is None else getattr(obj, name)


def pair_agreement(spec: RunSpec, mu_bar: float) -> float:
    """How closely (relative) the mean stresses of a run and its companion must agree for
    the pair to stop: within the run's error target, relative to mu_bar (the target is
    absolute); STEADY_AGREEMENT without a target."""
    if spec.target_error is None or not (mu_bar and math.isfinite(mu_bar)):
        return STEADY_AGREEMENT
    return spec.target_error / mu_bar


def stop_now(stops: list, step: int) -> bool:
    """The stop rule of an adaptive run at ``step``: its own (``stops[0]``), and with a
    companion (``stops[1]``) the pair's (``bkflow.observables.pair.pair_rule``): each leg's
    state allows a stop, neither remembers its start beyond both errors, and with an error
    target the pair's mean of mu_bar is within it and their mean stresses agree within it."""
    if len(stops) == 1 or stops[1] is None:
        # alone, or beside a companion with no rule of its own (a fixed-length protocol's run
        # with only an error target): the run's own rule decides
        return stops[0].reached(step)
    for stop in stops:   # every leg reads its new samples
        stop.reached(step)
    main, comp = stops
    if main.last is None or comp.last is None:
        return False
    target, spec = main.spec.target_error, main.spec
    t, sigma, weights, t0 = main.series
    tc, sc, wc, _ = comp.series
    if len(tc) != len(t):   # (the legs advance together: never, but said rather than assumed)
        return False
    main.both = states.window(spec, t, 0.5 * (sigma + sc), None, t0, own_error=False,
                              weights=weights)
    paired = comp.has_slips   # the pair's estimate, as the summary reports it
    d = pair.pair_rule(main.leg(), comp.leg(), main.both, target if paired else None,
                       STEADY_AGREEMENT, STEADY_DRIFT_BOUND, spec.until_steady)
    main.companion_gap, main.pair_disagrees, main.pair_state = d.gap, d.disagrees, d.state
    main.pair_legs = 2 if paired else 1
    if paired:
        main.mu_bar, main.last_error = d.mu_bar.value, d.mu_bar.err
        main.met = d.stop
    else:   # a companion that keeps no slips (recorded so before 0.6): the run's own error
        main.met = d.stop and (target is None or main.error_met(main.last_error, target))
    return main.met


def rule_met_at(spec: RunSpec, rd: RunDir, step: int) -> bool:
    """Whether ``spec``'s stop rule is met, on the finished run's records in ``rd`` (and its
    companion's), at its last step ``step``: what a run asked for with ``spec`` from the start
    would find at that check (a stricter request of a run that stopped by its rule may be met
    where the run stopped already)."""
    stops = [AdaptiveStop(spec, rd)]
    if spec.companion is not None:
        stops.append(AdaptiveStop(spec.companion_spec, rd.companion()))
    return stop_now(stops, step)


def _err(e) -> float:
    return math.nan if e is None else float(e)


#: an adaptive run's checks grow apart with its length: the next one comes after
#: max(chunk, CHECK_GROWTH x the steps so far) (in whole chunks), so that a long run checks a
#: few hundred times, not once every 100 time units (each check reads the whole window), and
#: stops at most CHECK_GROWTH later than a check at every chunk would have
CHECK_GROWTH = 0.05


def next_check(step: int, chunk: int) -> int:
    """The first step after ``step`` at which an adaptive run checks its stop rule: the
    checks are c_0 = 0, c_k+1 = c_k + max(chunk, chunk floor(CHECK_GROWTH c_k / chunk)), the
    same for a run and for its continuation."""
    c = 0
    while c <= step:
        c += max(chunk, chunk * int(CHECK_GROWTH * c // chunk))
    return c


def check_chunk(spec: RunSpec, chunk_steps: int | None) -> int:
    """Steps between the first checks of an adaptive run's stop rule: ADAPTIVE_CHUNK_T time
    units (at least 1000 steps), whatever the run's cap, so that a run asked for with a
    larger cap, or a smaller error target, checks at the very steps the shorter request
    checked, and a continued run is the run the longer request makes from the start; a fixed
    run has none (the whole run), unless ``chunk_steps``."""
    if chunk_steps:
        return chunk_steps
    if not spec.adaptive:
        return spec.n_steps
    return max(1000, int(round(ADAPTIVE_CHUNK_T / spec.dt)))
