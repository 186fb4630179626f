"""The verdict on recorded long runs of each state (benchmarks/records/stiff_states: blocks of
1000 time units, bkflow.observables.switching.block_verdict): a stiff layer's quiet and coherent
stretches are named as such, a window across a switch names both, a soft layer's window is steady,
and the synchronized start's plateau is its memory; each error covers the layer's long-run mean,
which the records hold (every start of the layer pooled)."""

from __future__ import annotations

import pandas as pd
import pytest

from bkflow.observables import switching
from tests.support import ROOT

RECORDS = ROOT / "benchmarks" / "records" / "stiff_states"


def _long_run(n: int, phi: float, seed: int) -> float:
    """The layer's long-run mean stress ratio: every start's blocks after its first 20%."""
    parts = []
    for f in RECORDS.glob(f"N{n}_phi{phi:g}_*_s{seed}_*.parquet"):
        r = pd.read_parquet(f)
        parts.append(r.iloc[int(0.2 * len(r)):])
    b = pd.concat(parts)
    return float((b.s * b.n).sum() / b.n.sum())


@pytest.mark.parametrize("name, blocks, phi, want", [
    ("N100_phi1000_random_s1_C1", (200, 264), 1000.0, "quiet"),
    ("N100_phi1000_random_s3_C1", (400, 464), 1000.0, "coherent"),
    ("N100_phi1000_stratified_s3_C1", (680, 744), 1000.0, "quiet+coherent"),
    ("N100_phi0.1_random_s1_C0.1017", (100, 164), 0.1, "steady"),
    ("N100_phi30_random_s1_C0.3317", (100, 164), 30.0, "steady"),
    ("N100_phi1000_synchronized_s1_C1", (10, 26), 1000.0, "metastable"),
])
def test_the_verdict_names_the_recorded_state(name, blocks, phi, want):
    r = pd.read_parquet(RECORDS / f"{name}.parquet").iloc[slice(*blocks)]
    got, mean, err = switching.block_verdict(r.t0, r.t1, r.s, r.R, r.R2abs, r.Zre, r.Zim, r.n,
                                          phi, 100)
    assert got == want
    if want != "metastable":   # the memory of the start is not the layer's: no error covers it
        seed = int(name.split("_")[-2][1:])
        assert abs(mean - _long_run(100, phi, seed)) <= 1.96 * err
