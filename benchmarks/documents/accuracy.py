"""The blocks of RESULTS.md's "The time step from accuracy" and "Work-precision": the runs of
benchmarks/measure/timestep.py as benchmarks/report/timestep.py and
benchmarks/report/work_precision.py read them, and the accuracy presets bkflow defines.
"""

from __future__ import annotations

from functools import lru_cache

from benchmarks.documents.cells import pct, se


@lru_cache(maxsize=1)
def timestep_runs():
    from benchmarks.measure.timestep import OUT
    from benchmarks.report import timestep as tr

    runs = tr.load(OUT)
    return tr, runs, tr.bias(runs)


def timestep_bias() -> str:
    tr, runs, table = timestep_runs()
    out = ["| N | phi | C = dt omega_max | omega_c dt | seeds | bias of <sigma_x>/sigma_n | "
           "bias of mu_bar | steps per time unit |", "|---|---|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        if r.reference:
            out.append(f"| {int(r.N)} | {r.phi:g} | {r.C:g} | {r.wc_dt:.3f} | {int(r.seeds)} | "
                       "(reference) | (reference) | " f"{r.steps_per_t:.0f} |")
            continue
        out.append(f"| {int(r.N)} | {r.phi:g} | {r.C:g} | {r.wc_dt:.3f} | {int(r.seeds)} | "
                   f"{pct(r.stress_bias)} +- {se(r.stress_se)} | "
                   f"{pct(r.mu_bar_bias)} +- {se(r.mu_bar_se)} | {r.steps_per_t:.0f} |")
    return "\n".join(out) + "\n"


def timestep_presets() -> str:
    """Each preset before (one C for every phi) and after (the rule), side by side: its step,
    cost and measured bias, and the verdict against its target."""
    tr, runs, table = timestep_runs()
    pr = tr.presets(table)
    out = ["| preset (target) | N | phi | rule | C = dt omega_max | omega_c dt | steps per time "
           "unit | bias <sigma_x>/sigma_n | bias mu_bar | verdict |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in pr.iterrows():
        how = "" if r.measured else " (interpolated)"
        out.append(f"| {r.preset} ({100 * r.target:g}%) | {int(r.N)} | {r.phi:g} | {r.rule} | "
                   f"{r.C:.3g} | {r.wc_dt:.3f} | {r.steps_per_t:.0f} | "
                   f"{pct(r.stress_bias)} +- {se(r.stress_se)} | "
                   f"{pct(r.mu_bar_bias)} +- {se(r.mu_bar_se)} | {r.verdict}{how} |")
    return "\n".join(out) + "\n"


def timestep_cost() -> str:
    """Per preset and N: the cost of the rule against the one C before, over the phi measured
    (steps per time unit, after / before), and the worst verdict."""
    tr, runs, table = timestep_runs()
    pr = tr.presets(table)
    rank = {"meets": 0, "within noise": 1, "unresolved": 1, "fails": 2}
    out = ["| preset (target) | N | phi | steps per time unit before -> after | "
           "worst verdict before | worst verdict after |", "|---|---|---|---|---|---|"]
    for (name, n), g in pr.groupby(["preset", "N"], sort=False):
        b, a = g[g.rule == "before"], g[g.rule == "after"]
        steps = ", ".join(f"{x:.0f} -> {y:.0f}" for x, y in
                          zip(b.steps_per_t, a.steps_per_t))
        worst = [max(x.verdict, key=rank.get) for x in (b, a)]
        out.append(f"| {name} ({100 * g.target.iloc[0]:g}%) | {n} | "
                   f"{', '.join(f'{v:g}' for v in a.phi)} | {steps} | {worst[0]} | {worst[1]} |")
    return "\n".join(out) + "\n"


def accuracy_presets() -> str:
    """The accuracy presets as bkflow defines them now (bkflow.model.params.ACCURACY): the error
    target, the two constants of the time-step rule, the run lengths and the target error."""
    from bkflow.model.timestep import ACCURACY

    out = ["| preset | target bias of the time step | c_contact (omega_c dt) | c_stable "
           "(dt omega_max) | t_end, paper protocol | cap, steady protocol | target error of "
           "mu_bar |", "|---|---|---|---|---|---|---|"]
    for name, p in ACCURACY.items():
        out.append(f"| `{name}` | {100 * p.dt_error:g}% | {p.c_contact:g} | {p.c_stable:g} | "
                   f"{p.t_end:g} | {p.t_cap:g} | {p.target_error:g} |")
    return "\n".join(out) + "\n"


def work_precision() -> str:
    """Each accuracy preset at its own step: the bias of both observables against dt -> 0
    (benchmarks/report/work_precision.py's record)."""
    import pandas as pd

    from benchmarks.report import work_precision as wp
    from bkflow.model.timestep import ACCURACY

    t = pd.read_csv(wp.RECORD)
    pts = wp.preset_points(t)
    out = ["| preset (target) | N | phi | steps per time unit | bias <sigma_x>/sigma_n | "
           "bias mu_bar |", "|---|---|---|---|---|---|"]
    for _, r in pts.sort_values(["preset", "N", "phi"],
                                key=lambda c: c.map(list(ACCURACY).index)
                                if c.name == "preset" else c).iterrows():
        out.append(f"| {r.preset} ({100 * r.target:g}%) | {r.N} | {r.phi:g} | "
                   f"{r.steps_per_t:.0f} | {pct(r.stress_bias)} +- {se(r.stress_se)} | "
                   f"{pct(r.mu_bar_bias)} +- {se(r.mu_bar_se)} |")
    return "\n".join(out) + "\n"


#: the blocks this module makes, by name
BLOCKS = {"timestep-bias": timestep_bias,
          "timestep-presets": timestep_presets,
          "timestep-cost": timestep_cost,
          "accuracy-presets": accuracy_presets,
          "work-precision": work_precision}
