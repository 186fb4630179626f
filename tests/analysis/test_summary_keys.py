"""The summary's keys (bkflow.analysis.summary_keys): every key a summary holds is declared there
once with the observable that computes it, every observable gives its keys through one path
(``compute``), and what reads them (the keys a scene did not measure, results.csv's averaged
fields, the power-law verdicts, the added observables) follows the declaration."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bkflow.analysis import summary_keys as keys_
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
    declared = keys_.keys()
    assert set(summary) == set(declared), set(summary) ^ set(declared)
    names = [k.name for o in keys_.OBSERVABLES for k in o.keys]
    assert len(names) == len(set(names)), "a key declared twice"
    if scene == "friction":   # what the scene did not record holds its declared missing value
        missing = {k.name: k.missing for o in keys_.OBSERVABLES if o.needs is not None
                   for k in o.keys}
        assert {o.needs for o in keys_.OBSERVABLES} >= {"snapshots", "slips", "energy"}
        assert missing and all(_same(summary[k], v if not isinstance(v, float) else None)
                               for k, v in missing.items()), missing
    else:
        assert all(summary[k] is not None for k in keys_.observable("clusters").names
                   if not k.startswith("regime"))


def test_results_average_the_declared_keys_in_their_columns_order():
    averaged = [k.name for o in keys_.OBSERVABLES for k in o.keys if k.averaged]
    assert sorted(RESULT_FIELDS) == sorted(averaged) and len(set(averaged)) == len(averaged)
    assert RESULT_FIELDS == keys_.COLUMNS, "a column of bkflow's own moved or is not averaged"
    assert set(keys_.WITHIN_RUN_ERRORS) <= set(RESULT_FIELDS)


def test_every_observable_declares_how_its_keys_are_found():
    """One path: every observable computes its keys (bkflow's own as an added one) or names
    what writes them; a summary holds them in the order they are declared."""
    for o in keys_.OBSERVABLES:
        assert (o.compute is None) != (o.written_by is None), o.name
    with pytest.raises(ValueError, match="either compute or written_by"):
        keys_.Observable("x", (keys_.Key("x", "", "made up"),))


@pytest.mark.usefixtures("lammps")
def test_a_summary_is_every_observable_in_declaration_order(tmp_path):
    spec = RunSpec(**{**protocol_fields("paper"), "phi": 10.0, "Lx": 8, "Ly": 4, "seed": 1,
                      "t_end": 200.0, "scene": "full"})
    run(spec, tmp_path / "r", progress=False)
    written = analyze(tmp_path / "r")
    computed = [k.name for o in keys_.OBSERVABLES if o.compute is not None for k in o.keys]
    assert [k for k in written if k in computed] == computed
    assert written["potency_exponent"] is not None and written["energy_residual"] is not None


def test_an_added_observable_is_computed_printed_and_drawn(monkeypatch):
    def double_n(ctx):
        return {"two_n": 2.0 * ctx.spec.N}

    obs = keys_.Observable("two_n", (keys_.Key("two_n", "count", "twice N", averaged=True),),
                           compute=double_n, line="  2N = {two_n:g}", figure="two_n")
    monkeypatch.setattr(keys_, "OBSERVABLES", [*keys_.OBSERVABLES, obs])
    ctx = keys_.Context(RunSpec(phi=1.0), None, np.zeros(2), np.zeros(2), None, 0.0, None)
    assert obs.values(ctx) == {"two_n": 200.0}
    assert keys_.averaged_keys()[-1] == "two_n"
    assert keys_.averaged_keys()[:-1] == keys_.COLUMNS
    assert keys_.lines({"two_n": 200.0}) == ["  2N = 200"]
    assert keys_.lines({"two_n": None}) == []
    assert keys_.figures() == {"fig_two_n": "two_n"}
    bad = keys_.Observable("bad", obs.keys, compute=lambda ctx: {"other": 1})
    monkeypatch.setattr(keys_, "OBSERVABLES", [bad])
    with pytest.raises(ValueError, match="not its declared keys"):
        keys_.summary(ctx)
    absent = keys_.Observable("absent", obs.keys, compute=lambda ctx: None)
    assert math.isnan(absent.values(ctx)["two_n"])
    bare = keys_.Observable("bare", obs.keys, compute=lambda ctx: 2.0)   # a number, not a map
    with pytest.raises(TypeError, match="observable bare's compute returned a float"):
        bare.values(ctx)
    # one that needs a record the run's scene does not keep is not computed
    unrecorded = keys_.Observable("unrecorded", obs.keys, needs="energy",
                                  compute=lambda ctx: 1 / 0)
    monkeypatch.setattr(keys_, "OBSERVABLES", [unrecorded])
    assert math.isnan(keys_.summary(ctx)["two_n"])


def test_power_law_names_are_the_declared_ones():
    assert keys_.power_law_names("drop") == ("drop_power_law", "drop_fit_p",
                                                "drop_vs_lognormal", "drop_vs_lognormal_p")
    assert keys_.power_law_names("potency")[0] == "potency_power_law"
    with pytest.raises(KeyError):
        keys_.power_law_names("nothing")


def test_the_docs_table_lists_every_key():
    table = keys_.keys_table()
    assert all(f"| `{k}` |" in table for k in keys_.keys())
