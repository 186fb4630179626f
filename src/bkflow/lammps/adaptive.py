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
from bkflow.observables import states
from bkflow.observables.stationarity import mean_error
from bkflow.observables.stress import Zigzag
from bkflow.store.rundir import RunDir


class AdaptiveStop:
    """The stop rule of an adaptive run (RunSpec.adaptive), checked between chunks once the
    run is long enough (ADAPTIVE_T_MIN; STEADY_T_MIN for a run until steady), over the
    analysed window of the run so far (the transient rule of a fixed run of that length):

    - ``target_error``: mu_bar's standard error is below the target and reliable, the error
      that covers the layer's switching between states (``bkflow.observables.states``);
    - ``until_steady``: the window is ``steady`` (``bkflow.observables.states.window``: no
      memory of the start shown, no switching between states that the window has not averaged
      over, the stress trend-free), and the trend test excludes a drift above
      STEADY_DRIFT_BOUND.

    The run's records (fix bk/reduce: the extrema and the block sums,
    ``bkflow.observables.reduced``) are read at every check, as the summary reads them: the
    summary of the finished run finds the very same slips, error, trend and state. What the
    last check found is ``last`` (a ``bkflow.observables.states.Window``); ``record`` returns
    it as data (meta.json's ``adaptive``), and ``bkflow.cli.report.stop_line`` words it."""

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
        self.last_error = None      # mu_bar's error at the last check (covering the switching)
        self.own_error = None       # ... the run's own (the states' means it visited)
        self.companion_gap = None   # the pair's gap at the last check (the main run's rule)
        self.pair_disagrees = False

    @property
    def last_mean(self) -> float:
        return self.last.mean if self.last is not None else math.nan

    def error(self, t_transient: float):
        """mu_bar's own error over the slips after ``t_transient`` found so far."""
        return mean_error(self.fail[self.t_fail >= t_transient] / self.spec.sigma_n)

    def reached(self, step: int) -> bool:
        spec = self.spec
        t_min = STEADY_T_MIN if spec.until_steady else ADAPTIVE_T_MIN
        if step * spec.dt < min(t_min, spec.t_end):
            return False
        self.checks += 1
        red = self.rd.read_reduced(spec)
        if red.has_extrema and len(red.extrema):
            s = np.asarray(red.extrema["sigma"], float)
            final = len(s) - 1
            self.maxima += self.zigzag.feed(s[self.fed:final].tolist())[0]
            self.fed = final
            pending = copy.copy(self.zigzag).feed([s[final]])[0]
            at = np.asarray(self.maxima + pending, np.int64)
            self.fail = s[at]
            self.t_fail = red.sample_index()[at] * spec.stress_nevery * spec.dt
        t, sigma, phase = red.series()
        t0 = transient_step(spec.transient, step) * spec.dt
        self.last = win = states.window(spec, t, sigma, phase if spec.until_steady else None,
                                        t0, own_error=False, weights=red.weights())
        met = True
        switching = spec.until_steady and win.state in states.SWITCHING
        if spec.target_error is not None:
            est = self.error(t0)
            if est.n < 2:
                return False
            self.last_error = win.err_of("mu_bar", est.mean, est.error, spec.phi, spec.N)
            self.own_error = est.error
            # a layer that switches between states: what a run can give is the mean of the
            # states it visits (their own error), not the long-run mean, whose error falls
            # only as the switching is averaged over (states.needed_length; reported)
            err = est.error if switching else self.last_error
            met &= bool(est.reliable and err <= spec.target_error)
        if spec.until_steady:
            met &= bool(switching or (win.state == "steady"
                                      and win.trend.drift_bound <= STEADY_DRIFT_BOUND))
        self.met = met
        return met

    def record(self, requested: RunSpec, t_run: float, stopped_early: bool) -> dict:
        """What the stop rule found, as data (``bkflow.cli.report.stop_line`` words it)."""
        w = self.last
        trend, comp, contacts = _attr(w, "trend"), _attr(w, "comp"), _attr(w, "contacts")
        needed = None
        if requested.target_error is not None and self.last_error is not None:
            needed = states.needed_length(requested, self.error(0.0).mean
                                          if len(self.fail) else math.nan)
        return {"target_error": requested.target_error,
                "until_steady": requested.until_steady,
                "drift_bound_required": STEADY_DRIFT_BOUND if requested.until_steady else None,
                "agreement_required": STEADY_AGREEMENT if requested.companion else None,
                "t_cap": requested.t_end, "t_run": t_run,
                "reached": bool(stopped_early or self.met),
                "mu_bar_err_at_stop": self.last_error,
                "mu_bar_own_err_at_stop": self.own_error,
                "state_at_stop": _attr(w, "state"),
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
                "checks": self.checks}


def _attr(obj, name: str):
    """``obj.name``, or None where there is no ``obj``."""
    return None if obj is None else getattr(obj, name)


def stop_now(stops: list, step: int) -> bool:
    """The stop rule of an adaptive run at ``step``: its own (``stops[0]``), and with a
    companion (``stops[1]``), the companion's too and the agreement of their mean stresses
    (within STEADY_AGREEMENT, or their errors: ``bkflow.observables.states.pair_disagrees``)."""
    if len(stops) == 1 or stops[1] is None:
        # alone, or beside a companion with no rule of its own (a fixed-length protocol's run
        # with only an error target): the run's own rule decides
        return stops[0].reached(step)
    reached = [stop.reached(step) for stop in stops]  # every leg reads its new samples
    main, comp = stops
    if main.last is None or comp.last is None:
        return False
    main.companion_gap = main.last_mean / comp.last_mean - 1 if comp.last_mean else math.nan
    main.pair_disagrees = states.pair_disagrees(main.last, comp.last, STEADY_AGREEMENT)
    ok = all(reached) and not main.pair_disagrees
    main.met = ok
    return ok


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
    """Steps between checks of an adaptive run's stop rule: 1% of the run (at least 1000), at
    most ADAPTIVE_CHUNK_T; a fixed run has none (the whole run), unless ``chunk_steps``."""
    if chunk_steps:
        return chunk_steps
    if not spec.adaptive:
        return spec.n_steps
    chunk = max(1000, spec.n_steps // 100)
    return max(1, min(chunk, int(round(ADAPTIVE_CHUNK_T / spec.dt))))
