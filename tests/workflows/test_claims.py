"""The paper's claims as workflows/paper/claims.py decides them: each test on cases whose
answer is known, and the documents rendered from its record (numbers.md's "Claims" section,
REPRODUCTION.md's blocks: tests/test_results_blocks.py) equal to what the record gives."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "workflows" / "paper"


def _claims():
    spec = importlib.util.spec_from_file_location("claims", PAPER / "claims.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


claims = _claims()


def test_an_interior_dip_counts_only_beyond_two_combined_errors():
    phi = [0.1, 1, 10, 100, 1000]
    y = [0.120, 0.118, 0.110, 0.116, 0.119]
    m = claims.minimum(phi, y, [0.001] * 5)
    assert m["phi"] == 10 and m["interior"] and m["non_monotonic"]
    assert m["z_hi"] == pytest.approx(0.009 / math.hypot(0.001, 0.001))
    # the same dip under errors four times larger: not significant, and the power says so
    m = claims.minimum(phi, y, [0.004] * 5)
    assert not m["non_monotonic"] and m["dip80"] == pytest.approx(2.84 * math.hypot(0.004, 0.004))
    # the lowest point at an end is never non-monotonic
    m = claims.minimum(phi, [0.12, 0.118, 0.116, 0.114, 0.11], [1e-6] * 5)
    assert not m["interior"] and not m["non_monotonic"] and m["z_lo"] is None


def test_the_dip_is_found_with_the_power_it_claims():
    """On synthetic curves with a true dip equal to dip80 (seeds drawn around it, the error
    the standard error of their mean), the test finds it in about 80% of trials."""
    rng = np.random.default_rng(3)
    phi = np.array([0.1, 1, 10, 100, 1000])
    sd, seeds = 0.003, 10
    sem = sd / math.sqrt(seeds)
    dip = (claims.Z + claims.Z_POWER) * math.hypot(sem, sem)
    truth = np.array([0.12, 0.12, 0.12 - dip, 0.12, 0.12])
    found = 0
    trials = 400
    for _ in range(trials):
        draws = truth + rng.normal(0, sd, (seeds, 5))
        m = claims.minimum(phi, draws.mean(0), draws.std(0, ddof=1) / math.sqrt(seeds))
        found += m["non_monotonic"] and m["phi"] == 10
    # about 80% (the sample errors and the choice of the lowest point move it a little)
    assert 0.6 < found / trials < 0.9


@pytest.mark.parametrize("n_x, n_y, expected", [(20, 5, "whole"), (20, 2, "row"),
                                                (1, 5, "column"), (3, 2, "patch")])
def test_shape_classes(n_x, n_y, expected):
    assert claims.shape_class([n_x], [n_y], 20, 5)[0] == expected


def test_eq2_makes_rows_cheapest_for_small_slips_and_columns_past_delta_star():
    """Eq. 2 on 20x5: a row costs k_b Lx ((delta^2 + 1)^(1/2) - 1)^2, a column k_b Ly
    delta^2; the column wins above delta* = 2a / (1 - a^2), a = (Ly/Lx)^(1/2) = 0.5, 4/3."""
    n_c = np.array([5, 5, 20, 20])
    delta = np.array([0.1, 2.0, 0.1, 2.0])
    best = claims.cheapest_shape(n_c, delta, 20, 5)
    # five sites: a strip of 5 x 1 (no side spans, so both terms count) beats one column
    # (1 x 5, n_y = Ly: only the term across) at both slips: 0.0101 against 0.05, 11.6
    # against 20
    assert best[0] == "patch" and best[1] == "patch"
    # twenty sites: one row (spans x) for a small slip, four columns for a large one
    assert best[2] == "row" and best[3] == "column"


def test_kappa_is_agreement_beyond_chance():
    a = np.array(["row"] * 50 + ["column"] * 50)
    assert claims.kappa(a, a) == 1.0
    # b agrees with a on 50% of the items, as two independent labels of these frequencies do
    b = np.array(["row", "column"] * 50)
    assert claims.kappa(a, b) == pytest.approx(0.0)
    # always the majority class: high raw agreement, no skill
    c = np.array(["row"] * 90 + ["column"] * 10)
    assert np.mean(c == np.array(["row"] * 100)) == 0.9
    assert claims.kappa(c, np.array(["row"] * 100)) == pytest.approx(0.0)


def _runs(rows):
    return pd.DataFrame(rows)


def test_regime_shares_weight_runs_by_their_clusters():
    runs = _runs([{"n_clusters": 30, "regime_fractions[DT]": 1.0},
                  {"n_clusters": 10, "regime_fractions[DT]": 0.0}])
    assert claims.cluster_share(runs, "DT") == pytest.approx(0.75)
    assert math.isnan(claims.cluster_share(runs.assign(n_clusters=0), "DT"))


def test_aspect_claim_takes_its_error_from_the_seeds():
    rows = []
    for seed, dt in ((1, 0.0), (2, 0.02), (3, 0.01)):
        rows.append({"Lx": 10, "Ly": 10, "seed": seed, "phi": 1.0, "n_clusters": 100,
                     "regime_fractions[DT]": dt, "regime_fractions[W]": 0.5})
    a = claims.claim5(_runs(rows), [(10, 10), (20, 5)])
    v = a["10x10"]
    assert v["DT"] == pytest.approx(0.01) and v["seeds"] == 3
    assert v["DT_sem"] == pytest.approx(np.std([0, 0.02, 0.01], ddof=1) / math.sqrt(3))
    assert v["upper"] == pytest.approx(0.01 + 2 * v["DT_sem"])
    assert "20x5" not in a
    assert "not reproduced" in claims.verdict5({"claim5": a}) or "partly" in \
        claims.verdict5({"claim5": a})


def test_numbers_md_shows_the_claims_record():
    """numbers.md's "Claims" section is the record claims.json rendered (one source): a
    number changed in either makes this fail."""
    record = PAPER / "claims.json"
    numbers = (PAPER / "numbers.md").read_text()
    if not record.exists():
        pytest.skip("no claims record yet (python workflows/paper/reproduce.py)")
    rec = json.loads(record.read_text())
    section = numbers[numbers.index("## Claims"):]
    assert section.strip() == claims.render_all(rec).strip()
