"""The steady protocol's pair: a run and its companion from another start, one layer seen
from either side of its steady state (docs/steady.md). Their mean and the error that covers
half their difference (``pair_mean``), whether they disagree beyond both errors
(``pair_disagrees``), and the rule that says when the pair may stop (``pair_rule``).

Pure functions on ``bkflow.observables.states.Window``s and numbers, like ``states``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bkflow.observables.states import STATE_NAMES, SWITCHING, Window


def pair_disagrees(a: Window, b: Window, agreement: float) -> bool:
    """Whether two windows of one layer (a run and its companion from another start) differ
    by more than ``agreement`` (relative) and more than twice their combined error: one of
    them still remembers its start."""
    if not (math.isfinite(a.mean) and math.isfinite(b.mean) and b.mean):
        return False
    gap = abs(a.mean / b.mean - 1)
    ea, eb = a.err_verdict, b.err_verdict
    both = math.hypot(ea / abs(a.mean), eb / abs(b.mean)) \
        if math.isfinite(ea) and math.isfinite(eb) else 0.0
    return gap > max(agreement, 2 * both)


@dataclass(frozen=True)
class PairMean:
    """The mean of one observable over a run and its companion from another start (the
    steady protocol's pair, docs/steady.md): ``value`` their mean, ``a`` and ``b`` each one's,
    ``noise`` the error of the mean from the two errors (each covering the switching),
    ``bracket`` half their difference, and ``err`` the larger of the two.

    Why the bracket: the two starts approach the steady state from either side (the random
    start from below, the partial one from above or, at N = 400, from just below), and the
    part of either that still remembers its start has one sign for every seed, which no
    error of a single run shows and no average over seeds removes. The long-run mean then lies
    between them, within half their difference of their mean; once the pair agrees that
    bound is below the noise."""

    value: float
    a: float
    b: float
    noise: float
    bracket: float

    @property
    def err(self) -> float:
        """The larger of the noise and the bracket; NaN where either leg's error is unknown
        (a leg with fewer than two slips: the bracket alone would say nothing of the noise)."""
        if not (math.isfinite(self.noise) and math.isfinite(self.bracket)):
            return math.nan
        return max(self.noise, self.bracket)

    @property
    def gap(self) -> float:
        """a / b - 1: how far the run lies from its companion, relative."""
        return self.a / self.b - 1 if self.b else math.nan


def pair_mean(a: float, err_a: float, b: float, err_b: float) -> PairMean:
    """The ``PairMean`` of values ``a`` and ``b`` with their errors (NaN where unknown: the
    noise and the error are then NaN)."""
    noise = math.hypot(err_a, err_b) / 2 if math.isfinite(err_a) and math.isfinite(err_b) \
        else math.nan
    return PairMean(0.5 * (a + b), a, b, noise, 0.5 * abs(a - b))


def pair_verdict(main: str, other: str, both: Window | None, disagree: bool) -> str:
    """The verdict of a run and its companion (``bkflow.observables.states.VERDICTS``):
    metastable when either holds its start's common phase, or their means disagree beyond
    both errors; the states either visited where either names its states; else the trend of
    the pair's mean (``both``: the window of the mean of their two stress series, what the
    pair reports), drifting or steady. One test of the pair's mean rather than one per run:
    a run's trend that its companion does not share, the two approaching from either side,
    is their gap's, which the pair's disagreement and its bracket judge; and two tests would
    call twice as many flat pairs drifting. Without ``both`` (a pair recorded without it),
    drifting when either drifts."""
    if disagree or "metastable" in (main, other):
        return "metastable"
    if main in SWITCHING or other in SWITCHING:
        seen = {s for v in (main, other) if v in SWITCHING for s in v.split("+")}
        return "+".join(s for s in STATE_NAMES if s in seen)
    if both is None:
        return "drifting" if "drifting" in (main, other) else "steady"
    return "steady" if both.trend.stationary else "drifting"


@dataclass(frozen=True)
class Leg:
    """What the stop rule of a run in progress knows of one leg at a check: its window (a
    ``Window``), and mu_bar over its slips after the transient with the error that covers the
    switching (``mu_err``, NaN where not measurable) and whether that estimate is
    reliable."""

    window: Window
    mu_bar: float
    mu_err: float
    reliable: bool


@dataclass(frozen=True)
class PairDecision:
    """The steady protocol's decision at a check (``pair_rule``)."""

    stop: bool
    state: str                  # the pair's verdict (pair_verdict)
    mu_bar: PairMean            # the pair's mean of mu_bar, with its error
    gap: float                  # main / companion - 1 of the mean stresses
    agreement: float            # the gap the rule allows (relative)
    disagrees: bool             # beyond both errors (pair_disagrees): a start remembered


def pair_rule(main: Leg, comp: Leg, both: Window, target: float | None,
              agreement_without_target: float, drift_bound: float,
              until_steady: bool = True) -> PairDecision:
    """Whether a run and its companion from the other start may stop: ``until_steady``, the
    pair's verdict (``pair_verdict``) is steady with a drift above ``drift_bound`` excluded
    (the trend of the pair's mean, ``both``), or names the states of a layer that switches,
    and neither remembers its start beyond both errors; and, with an error
    ``target`` (absolute, of mu_bar): the pair's mean of mu_bar (``pair_mean``: the noise of
    both, each covering the switching, or half their difference where larger) has an error
    within it, both estimates reliable, and their mean stresses agree within it, relative to
    mu_bar. A start approaching the steady state from one side therefore keeps the pair going
    until it is within the target of the other, whatever the switching's error
    (tests/observables/test_states.py, on a synthetic approach from below)."""
    mu = pair_mean(main.mu_bar, main.mu_err, comp.mu_bar, comp.mu_err)
    a, b = main.window.mean, comp.window.mean
    gap = a / b - 1 if b and math.isfinite(a) and math.isfinite(b) else math.nan
    disagrees = pair_disagrees(main.window, comp.window, agreement_without_target)
    state = pair_verdict(main.window.state, comp.window.state, both, disagrees)
    stop = not until_steady or state in SWITCHING or (
        state == "steady" and both.trend.drift_bound <= drift_bound)
    agreement = agreement_without_target
    if target is not None:
        agreement = target / mu.value if mu.value > 0 else math.nan
        stop = stop and main.reliable and comp.reliable and math.isfinite(mu.err) \
            and mu.err <= target and abs(gap) <= agreement
    return PairDecision(bool(stop), state, mu, gap, agreement, disagrees)
