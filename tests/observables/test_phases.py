"""The contacts' phase statistics (bkflow.observables.phases) on synthetic series whose answers are
known: the phase fluctuation of independent contacts is 1 - |c|^2 whatever their common
distribution, contacts that keep a common phase give N R^2 (the verdict that reads them:
tests/observables/test_states.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bkflow.observables.phases import coherence
from bkflow.observables.states import MEMORY_CHI_DEFAULT


def independent_phases(rng, n_contacts, n_times, sampler):
    """Z(t) of contacts that draw their phases independently at every time from one
    distribution (``sampler(rng, shape)`` -> phases in [0, 1))."""
    u = sampler(rng, (n_times, n_contacts))
    return np.exp(2j * np.pi * u).mean(axis=1)


def uniform(rng, shape):
    return rng.uniform(0, 1, shape)


def skewed(rng, shape):
    """A steady, non-uniform phase distribution (a contact lingers near u = 0.2)."""
    return np.mod(0.2 + 0.15 * rng.standard_normal(shape), 1.0)


@pytest.mark.parametrize("sampler, n", [(uniform, 100), (skewed, 100), (skewed, 900)])
def test_independent_contacts_fluctuate_as_one_minus_c_squared(sampler, n):
    """The estimator on series with a known answer: E[chi] = 1 - |c|^2, c = E[exp(2 pi i u)],
    to 5% over 4000 samples; for the skewed distribution R is far from 1/sqrt(N) yet chi
    stays below 1 (a non-uniform steady distribution is not a coherence)."""
    rng = np.random.default_rng(n)
    t = np.arange(4000.0)
    Z = independent_phases(rng, n, len(t), sampler)
    c = np.exp(2j * np.pi * sampler(rng, 400_000)).mean()
    co = coherence(t, Z, 0.0, n)
    assert co.fluctuation == pytest.approx(1 - abs(c) ** 2, rel=0.05)
    assert co.R_static == pytest.approx(abs(c), abs=0.02)
    assert co.fluctuation < 1.2  # far below any memory of a common phase
    if sampler is skewed:
        assert co.R > 3 / math.sqrt(n)


@pytest.mark.parametrize("n", [100, 400])
def test_contacts_sharing_a_turning_phase_are_coherent(n):
    """The synchronized start's memory: a cluster of contacts sharing one phase that goes
    round the load cycle (period 5.3 time units) on top of independent ones: chi is about
    N R^2 (the turning part), far above the threshold, and grows with N."""
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 6000.0)
    cluster = 0.55 * np.exp(2j * np.pi * t / 5.3)
    Z = cluster + 0.45 * independent_phases(rng, n, len(t), uniform)
    co = coherence(t, Z, 1200.0, n)
    assert co.fluctuation == pytest.approx(n * 0.55 ** 2, rel=0.1)
    assert co.fluctuation > 2 * MEMORY_CHI_DEFAULT
    assert co.R == pytest.approx(0.55, abs=0.05) and co.R_static < 0.05


def test_a_window_without_samples_has_no_fluctuation():
    co = coherence(np.arange(10.0), np.ones(10), 100.0, 100)
    assert math.isnan(co.fluctuation)
