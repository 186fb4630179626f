"""The registry of the summary's keys (bkflow.analysis.registry): every key a summary holds is
declared there once, and what reads it (the keys a scene did not measure, results.csv's
averaged fields, the power-law verdicts, the added observables) follows the declaration."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bkflow.analysis import registry
from bkflow.analysis.results import RESULT_FIELDS
from bkflow.analysis.summary import analyze
from bkflow.lammps.engine import run
from bkflow.model.params import RunSpec
from bkflow.model.protocols import protocol_fields


def _same(a, b) -> bool:
    return (a is None and b is None) or a == b or (
        isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))


@pytest.mark.usefixtures("lammps")
@pytest.mark.parametrize("scene", ["friction", "full"])
def test_every_key_of_a_summary_is_declared_once(tmp_path, scene):
    spec = RunSpec(**{**protocol_fields("paper"), "phi": 100.0, "Lx": 8, "Ly": 4, "seed": 2,
                      "t_end": 300.0, "scene": scene})
    run(spec, tmp_path / "r", progress=False)
    analyze(tmp_path / "r")
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    declared = registry.keys()
    assert set(summary) == set(declared), set(summary) ^ set(declared)
    names = [k.name for o in registry.OBSERVABLES for k in o.keys]
    assert len(names) == len(set(names)), "a key declared twice"
    if scene == "friction":   # what the scene did not record holds its declared missing value
        missing = registry.not_measured("snapshots", "slips", "ledger")
        assert missing and all(_same(summary[k], v if not isinstance(v, float) else None)
                               for k, v in missing.items()), missing
    else:
        assert all(summary[k] is not None for k in registry.observable("clusters").names
                   if not k.startswith("regime"))


def test_results_average_the_declared_keys_in_their_declared_places():
    averaged = [k for o in registry.OBSERVABLES for k in o.keys if k.averaged]
    assert RESULT_FIELDS == tuple(k.name for k in sorted(averaged, key=lambda k: k.averaged))
    places = [k.averaged for k in averaged]
    assert sorted(places) == list(range(1, len(places) + 1)), "a column place given twice"
    assert set(registry.WITHIN_RUN_ERRORS) <= set(RESULT_FIELDS)


def test_an_added_observable_is_computed_printed_and_drawn(monkeypatch):
    def double_n(ctx):
        return {"two_n": 2.0 * ctx.spec.N}

    obs = registry.Observable("two_n", (registry.Key("two_n", "count", "twice N",
                                                     averaged=True),),
                              compute=double_n, line="  2N = {two_n:g}", figure="two_n")
    monkeypatch.setattr(registry, "OBSERVABLES", [*registry.OBSERVABLES, obs])
    ctx = registry.Context(RunSpec(phi=1.0), None, np.zeros(2), np.zeros(2), None, 0.0)
    assert registry.compute_added(ctx) == {"two_n": 200.0}
    assert registry.averaged_keys()[-1] == "two_n"
    assert registry.lines({"two_n": 200.0}) == ["  2N = 200"]
    assert registry.lines({"two_n": None}) == []
    assert registry.figures() == {"fig_two_n": "two_n"}
    bad = registry.Observable("bad", obs.keys, compute=lambda ctx: {"other": 1})
    monkeypatch.setattr(registry, "OBSERVABLES", [bad])
    with pytest.raises(ValueError, match="not its declared keys"):
        registry.compute_added(ctx)


def test_power_law_names_are_the_declared_ones():
    assert registry.power_law_names("drop") == ("drop_power_law", "drop_fit_p",
                                                "drop_vs_lognormal", "drop_vs_lognormal_p")
    assert registry.power_law_names("potency")[0] == "potency_power_law"
    with pytest.raises(KeyError):
        registry.power_law_names("nothing")


def test_the_docs_table_lists_every_key():
    table = registry.keys_table()
    assert all(f"| `{k}` |" in table for k in registry.keys())
