"""What bkflow says of its results, in words: every line the command line prints about what a
command did (a run's summary, its stop, a deck or figures written, a sweep's plan, table and
outcome) is made here, from the data the engine, the analysis and the sweep return; neither
of them writes prose.

The verdicts are those of ``bkflow.observables.states.VERDICTS`` (docs/model.md "Steady state").
"""

from __future__ import annotations

import math
import sys

from bkflow.analysis.summary_keys import lines as observable_lines
from bkflow.analysis.summary_keys import power_law_names
from bkflow.model.params import STEADY_AGREEMENT
from bkflow.observables.states import SWITCHING
from bkflow.store import layout
from bkflow.store.files import shell_word


def _num(s: dict, key: str, scale: float = 1.0) -> float:
    v = s.get(key)
    return float("nan") if v is None else scale * v


def _g(s: dict, key: str, fmt: str) -> str:
    v = s.get(key)
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) \
        else format(v, fmt)


# ------------------------------------------------------------------------- a run, a deck
def run_line(out, meta: dict) -> str:
    """What a finished run took: its steps, wall time, rate, path and contact breaks."""
    eng = meta["engine"]
    pair = " (and as many for its companion)" if meta.get("companion") else ""
    return (f"{out}: {meta['derived']['n_steps']} steps{pair} in {meta['wall_time_s']:.1f} s "
            f"({meta['atom_steps_per_s']:.3g} atom-steps/s, {eng['path']} path"
            + (f", {eng['kernel']} kernel" if eng["kernel"] else "")
            + f"), {meta['contact_breaks']} contact breaks")


def analysing_again_line(out) -> str:
    return f"{out}: this run finished earlier; analysing it"


def analysed_line(run_dir, why: str | None) -> str:
    """bkflow analyze's summary written, and why it was made again (``why``: what made the
    one there stale)."""
    return (f"{run_dir}/{layout.SUMMARY} written"
            + (f" (re-analysed: {why})" if why and not why.startswith("no ") else ""))


def deck_line(paths: dict, n_steps: int) -> str:
    return f"wrote {paths['deck']} and {paths['data']} ({n_steps} steps)"


def print_summary(s: dict) -> None:
    """A run's summary, printed (``summary_lines``)."""
    print("\n".join(summary_lines(s)))


# ------------------------------------------------------------------------- a run's state
def composition(s: dict) -> str:
    """The states a run visited: the share of time in each, with its mean stress."""
    parts = []
    for name in ("quiet", "coherent"):
        share = s.get(f"time_{name}")
        if share:
            parts.append(f"{name} {100 * share:.0f}% of the time (<sigma_x>/sigma_n "
                         f"{_g(s, f'mean_stress_ratio_{name}', '.4f')})")
    return ", ".join(parts)


def state_line(s: dict) -> str:
    """One line of what a summary says of its run's state (docs/model.md "Steady state"):
    the verdict, and the stress trend, the contacts' phases and the states it rests on."""
    window = f"t = {_num(s, 't_transient'):.0f}..{_num(s, 't_run'):.0f}"
    trend = (f"drift {_num(s, 'drift', 100):+.2f}% +- {_num(s, 'drift_err', 100):.2f}%, "
             f"z = {_num(s, 'drift_z'):.1f}")
    contacts = (f"phase fluctuation {_num(s, 'phase_fluctuation'):.3g}, R = "
                f"{_num(s, 'phase_coherence'):.3f}") if s.get("contacts_recorded") else \
        "contacts not recorded: the verdict rests on the stress alone"
    state = s.get("state") or "drifting"
    pair = ""
    if s.get("companion_start"):
        pair = (f"; the companion run from the {s['companion_start']} start is "
                f"{s.get('companion_state')}, its mean stress "
                f"{_num(s, 'companion_gap', -100):+.2f}% from this run's")
    if s.get("drift") is None:
        return (f"DRIFTING (untested) over {window}: too short for the trend test's blocks; "
                "run longer")
    if state in SWITCHING:
        why = s.get("switching_not_calibrated_because")
        errors = ("its errors cover the switching (calibrated on long runs)" if not why else
                  f"its errors cover the switching as the nearest calibrated layer has it, "
                  f"wider ({why})")
        return (f"{state.upper()} over {window}: the layer switches between a quiet and a "
                f"coherent state more slowly than this window averages over them; this run "
                f"visited {composition(s) or 'n/a'}; {errors}{pair}")
    if state == "drifting":
        return (f"DRIFTING over {window}: the stress still drifts ({trend}); its numbers are "
                "a transient's")
    if state == "metastable" and s.get("contacts_coherent"):
        return (f"METASTABLE over {window}: the contacts still hold the start's common phase "
                f"({contacts}): the start is not forgotten, its numbers are not the steady "
                f"state's{pair}")
    if state == "metastable":
        return (f"METASTABLE over {window}: the stress disagrees with the other start's{pair} "
                f"(beyond {100 * STEADY_AGREEMENT:g}% and both errors): a start is not "
                "forgotten yet; run longer")
    return (f"steady over {window}: the stress is flat ({trend}; a drift up to "
            f"{_num(s, 'drift_bound', 100):.1f}% not excluded) and the contacts have forgotten "
            f"the start ({contacts}){pair}")


def power_law_line(s: dict, key: str, what: str) -> str:
    """The report's line on a power law of the summary's ``key``_* entries (their names
    declared in ``bkflow.analysis.summary_keys``)."""
    verdict, fit_p, vs_lognormal, vs_lognormal_p = power_law_names(key)
    exponent = (f"exponent {_g(s, f'{key}_exponent', '.2f')} +- "
                f"{_g(s, f'{key}_exponent_err', '.2f')}")
    p = _g(s, fit_p, ".3f")
    if s.get(verdict) == "rejected":
        R = s.get(vs_lognormal)
        vs = (f", against a lognormal R = {R:.1f}" if R is not None and math.isfinite(R)
              else "")
        return (f"  {what}: power law rejected (p = {p}{vs}); the fitted {exponent} does not "
                "describe them")
    if s.get(verdict) == "plausible":
        R, Rp = s.get(vs_lognormal), s.get(vs_lognormal_p)
        if R is not None and Rp is not None and R < 0 and Rp < 0.1:
            return (f"  {what}: the bootstrap does not rule a power law out (p = {p}), but a "
                    f"lognormal is favoured (R = {R:.1f}, p = {Rp:.2g}); the fitted {exponent} "
                    "is no law")
        return f"  {what}: power law, {exponent} (p = {p})"
    return f"  {what}: no power-law fit"


def estimate_lines(s: dict, state: str) -> list[str]:
    """What a summary's numbers are: the pair's means (with each run's own), an error borrowed
    where nothing is calibrated, and the length the error target would need."""
    lines = []
    if s.get("estimate") == "pair":
        lines.append(f"  each the mean of this run (mu_bar {_g(s, 'mu_bar_run', '.4f')}, "
                     f"<sigma_x>/sigma_n {_g(s, 'mean_stress_ratio_run', '.4f')}) and its "
                     f"companion from the {s.get('companion_start')} start (mu_bar "
                     f"{_g(s, 'companion_mu_bar', '.4f')}, <sigma_x>/sigma_n "
                     f"{_g(s, 'companion_mean_stress_ratio', '.4f')}): the two starts approach "
                     "the steady state from either side, and each error covers half their "
                     "difference")
    why = s.get("switching_not_calibrated_because")
    if why and state not in SWITCHING:
        lines.append(f"  not calibrated here ({why}): " + (
            "the errors are the run's own" if "installed" in why else
            "the errors cover the slow fluctuations of the nearest calibrated layer, wider"))
    if s.get("t_needed") is not None and s.get("t_needed") > _num(s, "t_run"):
        lines.append(f"  the error target {s['params']['target_error']:g} needs a run of about "
                     f"t = {s['t_needed']:.2g} (this layer's switching, calibrated on long "
                     "runs)")
    return lines


def threshold_line(s: dict) -> str:
    """mu_bar at each report threshold, and what its "n/a" means where it has one."""
    by = ", ".join(f"{k}: {'n/a' if v is None else format(v, '.4f')}"
                   for k, v in s["mu_bar_by_threshold"].items())
    return (f"  mu_bar by threshold (fraction of mu_s sigma_n): {by}"
            + ("; n/a: no slip dropped by that much" if "n/a" in by else ""))


def summary_lines(s: dict) -> list[str]:
    """The report of a run's summary (``bkflow run``, ``bkflow analyze``)."""
    state = s.get("state") or "drifting"
    lines = ["  " + state_line(s),
             f"  mu_bar = {_g(s, 'mu_bar', '.4f')} +- {_g(s, 'mu_bar_err', '.4f')} ({state}) "
             f"over {s['n_slips']} slips (threshold {s['slip_threshold_stress']:g}); "
             f"<sigma_x>/sigma_n = {_g(s, 'mean_stress_ratio', '.4f')} +- "
             f"{_g(s, 'mean_stress_ratio_err', '.4f')} ({state})"]
    lines += estimate_lines(s, state)
    if state in SWITCHING:
        per = [f"{name}: mu_bar {_g(s, f'mu_bar_{name}', '.4f')}, <sigma_x>/sigma_n "
               f"{_g(s, f'mean_stress_ratio_{name}', '.4f')}"
               for name in ("quiet", "coherent") if s.get(f"time_{name}")]
        lines.append("  by state (this run): " + "; ".join(per))
    lines += [f"  mu_bar over large drops (> {_g(s, 'large_drop_threshold', '.3g')}) = "
              f"{_g(s, 'mu_bar_large', '.4f')} +- {_g(s, 'mu_bar_large_err', '.4f')} over "
              f"{s.get('n_slips_large')} slips"]
    lines.append(threshold_line(s))
    if s.get("psi_inf") is not None:
        lines.append(f"  Psi(inf) = {s['psi_inf']:.4f}")
    if s.get("n_clusters") is not None:
        of = s.get("n_slips")
        lines.append(f"  clusters: {s['n_clusters']} in the {s['n_cluster_events']} slips whose "
                     "frames were found"
                     + (f" (of the {of} after the transient)" if of is not None and of !=
                        s["n_cluster_events"] else "") + ", "
                     f"<l_x/Lx> = {_g(s, 'lx_mean_over_Lx', '.3f')}, <l_y/Ly> = "
                     f"{_g(s, 'ly_mean_over_Ly', '.3f')}, <l_x>/<l_y> = "
                     f"{_g(s, 'lx_over_ly', '.3f')}, regime {s.get('regime') or 'n/a'} "
                     "(an extent near 1 spans its side; a whole-box slip's can exceed 1, "
                     "by N/(N-1))")
        lines.append(f"  clusters of large slips: {s.get('n_clusters_large')}, <l_x>/<l_y> = "
                     f"{_g(s, 'lx_over_ly_large', '.3f')}, regime "
                     f"{s.get('regime_large') or 'n/a'}")
    lines.append(power_law_line(s, "drop", f"stress drops ({s['drop_n_tail']} above "
                                f"{_g(s, 'drop_x_min', '.3g')})"))
    if s.get("potency_power_law") is not None:
        lines.append(power_law_line(s, "potency", f"potencies ({s['potency_n_tail']} above "
                                    f"{_g(s, 'potency_x_min', '.3g')})"))
    if s.get("energy_residual") is not None:
        lines.append(f"  energy: the balance (plate work = change of elastic and kinetic energy "
                     f"+ dissipation) closes to {_g(s, 'energy_residual', '.1e')} of the "
                     "plate's work over the analysed run")
    return lines + observable_lines(s)


# ------------------------------------------------------------------------- a sweep's table
def cost_line(total, jobs: int, adaptive: bool) -> str:
    """What a sweep will cost (``bkflow.lammps.limits.Cost`` of all its runs), before it starts."""
    from bkflow.lammps.limits import ATOM_STEPS_PER_SECOND, fmt_bytes
    from bkflow.sweeps.local import fmt_duration

    seconds = total.atom_steps / ATOM_STEPS_PER_SECOND / max(1, jobs)
    return (f"cost: {total.atom_steps:.3g} atom-steps, at most {fmt_duration(seconds)} on "
            f"{jobs} core(s) at {ATOM_STEPS_PER_SECOND:.0e} atom-steps/s"
            + (" if every run goes to its cap (a run stops earlier once its rule is met)"
               if adaptive else "")
            + (f", at most {fmt_bytes(total.disk_bytes)} on disk (as much less as the runs "
               "stop before their caps)" if adaptive else
               f", about {fmt_bytes(total.disk_bytes)} on disk"))



def sweep_plan_lines(phis, n_sizes: int, axes: dict, seeds: int, n_runs: int, out,
                     jobs: int, cost: str) -> list[str]:
    """What a sweep is about to run, before it starts (``cost``: ``cost_line``'s)."""
    extra = "".join(f" x {len(v)} {k}" for k, v in axes.items())
    return [f"sweep: {len(phis)} phi x {n_sizes} size(s){extra} x {seeds} seed(s) = "
            f"{n_runs} runs into {out}, {jobs} at a time",
            f"  phi = {', '.join(f'{p:g}' for p in phis)}",
            "  " + cost] + [f"  {k} = {', '.join(map(str, v))}" for k, v in axes.items()]


def jobs_created_lines(out, n_jobs: int, done: int) -> list[str]:
    """``bkflow sweep --init``: the jobs created, how to run them (with this Python, the one
    that has bkflow, whatever ``python`` names in the user's shell), and how to read them."""
    where, python = shell_word(out), shell_word(sys.executable)
    return [f"{out}: {n_jobs} jobs ({done} finished); run them here with",
            f"  (cd {where} && {python} -m bkflow.slurm run)",
            "or submit them to the cluster's scheduler with",
            f"  (cd {where} && {python} -m bkflow.slurm submit)",
            f"and once they are done, bkflow collect {where} writes the sweep's tables"]


def sweep_done_line(rep) -> str:
    """What a sweep ran (``bkflow.sweeps.local.SweepReport``)."""
    from bkflow.sweeps.local import fmt_duration

    return (f"{len(rep.finished)} run(s) done in {fmt_duration(rep.wall_time_s)}, "
            f"{rep.finished_before} finished earlier (skipped), {len(rep.failed)} failed"
            + (f" ({len(rep.reanalysed)} of them only re-analysed)" if rep.reanalysed else "")
            + (f", {len(rep.unfinished)} not finished" if rep.unfinished else "")
            + (f" ({len(rep.busy)} of them written by another process)" if rep.busy else ""))


def tables_line(out) -> str:
    """A sweep's tables written, and the command that draws its figures."""
    from bkflow.store.tables import RESULTS_FILE, RUNS_FILE

    return (f"wrote {out}/{RUNS_FILE} and {out}/{RESULTS_FILE}; figures: bkflow plot "
            f"{shell_word(out)}")


def retired_lines(root, removed) -> list[str]:
    """The figure files removed because the tables they were drawn from changed."""
    if not removed:
        return []
    return [f"removed {len(removed)} figure file(s) of {root}/figures drawn from the tables "
            "before (they no longer match them): bkflow plot "
            f"{shell_word(root)} draws them again"]


def run_failed_lines(rep) -> list[str]:
    """A sweep's runs that failed or were refused, one line each."""
    return [f"bkflow: {'refused' if job_id in rep.refused else 'run failed'}: {msg} "
            f"(job {job_id})" for job_id, msg in rep.failed.items()]


def sweep_outcome(rep) -> tuple[str, str] | None:
    """A sweep that did not finish every run: ("busy", "refused" or "failed", the line that
    says what to do); None when every run finished."""
    if rep.busy and not rep.failed and len(rep.busy) == len(rep.unfinished):
        return "busy", (f"bkflow: busy: {len(rep.busy)} run(s) are being written by another "
                        "process (e.g. python -m bkflow.slurm run); run the same command once "
                        "it is done")
    if rep.refused and len(rep.refused) == len(rep.failed) and not rep.unfinished:
        return "refused", (f"bkflow: {len(rep.refused)} run(s) refused: their directories hold "
                           "what bkflow does not replace or read (the lines above name it); "
                           "move that away, then the same command runs them")
    if rep.failed or rep.unfinished:
        return "failed", (f"bkflow: {len(rep.failed) + len(rep.unfinished)} run(s) did not "
                          "finish; the same command retries them"
                          + (f" ({len(rep.refused)} of them refused: move away what the lines "
                             "above name)" if rep.refused else ""))
    return None


def collect_line(sweep_dir, c) -> str:
    """What bkflow collect found (``bkflow.sweeps.local.collect``)."""
    return (f"{sweep_dir}: {c.jobs} jobs, {c.finished} finished, {len(c.failed)} failed, "
            f"{c.jobs - c.finished - len(c.failed)} not run; {len(c.reanalysed)} re-analysed")


def collected_tables_line(sweep_dir, c) -> str:
    from bkflow.store.tables import RESULTS_FILE, RUNS_FILE

    return (f"wrote {sweep_dir}/{RUNS_FILE} ({len(c.runs)} rows) and {sweep_dir}/"
            f"{RESULTS_FILE} ({len(c.results)} rows)")


def collect_problem_lines(sweep_dir, c) -> list[str]:
    """bkflow collect's failed jobs and damaged runs, for stderr."""
    return [f"  failed {j.id}: {j.document['error']}" for j in c.failed] + [
        f"bkflow: warning: run {job_id} is damaged ({why}) and left out of the tables: "
        f"collect does not run LAMMPS; the sweep's own command (bkflow sweep ... --out "
        f"{shell_word(sweep_dir)}) runs it again" for job_id, why in c.damaged]


def states_line(res, t_end: float | None = None) -> str:
    """How many runs of a results table are steady, switching, drifting, metastable, and what
    to do (``t_end``: the sweep's cap, for the advice)."""
    total = int(res.n_seeds.sum())

    def count(name):
        return int(res[f"n_{name}"].sum()) if f"n_{name}" in res else 0

    n = {k: count(k) for k in ("steady", "switching", "drifting", "metastable")}
    line = (f"{n['steady']} of {total} runs are steady over their analysed window, "
            f"{n['switching']} switching between states (named in column 'state', their "
            f"errors covering the switching), {n['drifting']} drifting, {n['metastable']} "
            "metastable")
    if n["drifting"] + n["metastable"]:
        longer = (f" (the same command with --t-end {2 * t_end:g} continues every run that "
                  "stopped at its cap, in place)") if t_end else ""
        line += ("; the numbers of the drifting and metastable ones are not the steady "
                 f"state's: run longer{longer}")
    return line


def cell_state(r) -> str:
    """A point's state for the printed table: the state, with the count of its seeds' runs
    when not all are steady."""
    state = r.get("state") if isinstance(r.get("state"), str) else "drifting"
    if state == "steady":
        return "steady"
    key = "n_switching" if state in SWITCHING else f"n_{state}"
    return f"{state} {int(r.get(key, 0))}/{int(r.n_seeds)}"


def _pm(v, e, fmt) -> str:
    """A value with its error to 2 digits (n/a for NaN)."""
    if v != v:
        return "n/a"
    return f"{v:{fmt}}" + (f" +- {e:.2g}" if e == e else "")


def _err(r, f):
    return r.get(f"{f}_err", r.get(f"{f}_sem"))


#: the sweep table's columns after the state: header, and the cell of a results row
RESULT_COLUMNS = (
    ("mu_bar", lambda r: _pm(r.mu_bar, _err(r, "mu_bar"), ".4f")),
    ("mu_bar (large)", lambda r: _pm(r.mu_bar_large, _err(r, "mu_bar_large"), ".4f")),
    ("<sigma_x>/sigma_n", lambda r: _pm(r.mean_stress_ratio, _err(r, "mean_stress_ratio"),
                                        ".4f")),
    ("Psi(inf)", lambda r: _pm(r.psi_inf, r.psi_inf_sem, ".3f")),
    ("<l_x>/<l_y>", lambda r: _pm(r.lx_over_ly, r.lx_over_ly_sem, ".2f")),
    ("regime", lambda r: r.regime if isinstance(r.regime, str) else "n/a"))


def _table_columns(rows, axes) -> list[tuple[str, list[str]]]:
    """The sweep table's columns (header, cells): the point's, then RESULT_COLUMNS but those
    no point has a value in."""
    columns = [("phi", [f"{r.phi:g}" for r in rows]),
               ("size", [f"{r.Lx}x{r.Ly}" for r in rows]),
               *[(k, [str(r[k]) for r in rows]) for k in axes],
               ("seeds", [str(r.n_seeds) for r in rows]),
               ("state", [cell_state(r) for r in rows])]
    for head, cell in RESULT_COLUMNS:
        cells = [cell(r) for r in rows]
        if any(c != "n/a" for c in cells):
            columns.append((head, cells))
    return columns


def results_lines(res, axes=()) -> list[str]:
    """The table a sweep prints: one row per point, every number with its error. Each column is
    as wide as its widest cell, and a column no point has a value in (an observable the sweep's
    scene does not record) is left out."""
    columns = _table_columns([r for _, r in res.iterrows()], axes)
    widths = [max([len(h)] + [len(c) for c in cells]) for h, cells in columns]
    return ["  " + "  ".join(f"{cell:>{w}}" for cell, w in zip(line, widths)).rstrip()
            for line in zip(*[[h] + cells for h, cells in columns])]


# ------------------------------------------------------------------------- figures
def plot_lines(paths, skipped: dict) -> list[str]:
    """bkflow plot's figures written, and those it could not draw, with why."""
    return [f"wrote {p}" for p in paths] + [f"skipped {name}: {why}"
                                           for name, why in skipped.items()]


def movie_line(path, fronts, dt: float, maps) -> str:
    """bkflow movie's GIF of one slip (``fronts``: its front record) and its maps."""
    return (f"wrote {path} ({len(fronts.steps)} frames, t = {fronts.step_max * dt:g} to "
            f"{fronts.step_min * dt:g}) and {maps}")
