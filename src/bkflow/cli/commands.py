"""bkflow: Burridge-Knopoff friction (Giacco et al. 2014) on LAMMPS, from one run to a sweep.

The commands: ``bkflow run``, ``sweep``, ``plot``, ``analyze``, ``collect``, ``deck`` and
``movie``.

Every expected failure is one line on stderr and an exit code of ``EXIT_CODES``: bad
input 2, a failed run 1, another process busy 3, the file system 4. Nothing half-written is
left looking complete: a run directory counts as finished only once its meta.json says so.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
from pathlib import Path

# every bkflow process is one single-threaded run (a sweep runs one process per core): the
# idle threads of NumPy's OpenBLAS spin, and on a small machine they steal LAMMPS's core
# (5% of a run's samples at N = 900 in perf). Set before NumPy loads; a user's value wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from bkflow import __version__  # noqa: E402
from bkflow.cli import report  # noqa: E402
from bkflow.model.params import (  # noqa: E402
    ACCURACY,
    ADAPTIVE_CHUNK_T,
    ADAPTIVE_T_MIN,
    CONTACT_RULE_HELP,
    CONTACT_RULES,
    DT_FACTOR_MAX,
    PAPER_SIZES,
    PATHS,
    PROTOCOLS,
    SCENES,
    STARTS,
    STEADY_AGREEMENT,
    STEADY_COMPANION,
    STEADY_DRIFT_BOUND,
    STEADY_START,
    AnalysisSettings,
    RunSpec,
    SpecError,
    parse_size,
    protocol_fields,
    size_from_n,
)
from bkflow.store import rundir as rd  # noqa: E402
from bkflow.store.formats import shell_word  # noqa: E402
from bkflow.sweeps.grid import ASPECT, POINTS_PER_DECADE, SEEDS  # noqa: E402

EXIT_RUN_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_BUSY = 3
EXIT_FILE_SYSTEM = 4
EXIT_RESOURCES = 5
EXIT_INTERNAL = 70
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141
#: what every exit code of bkflow means (README, "Exit codes")
EXIT_CODES = {
    0: "done",
    EXIT_RUN_FAILED: "a run failed (blew up, tore apart, LAMMPS error); nothing of it looks "
                     "finished",
    EXIT_BAD_INPUT: "bad input or a refused request (a bad argument, a directory that is not "
                    "bkflow's, a finished run without --overwrite, a damaged run, a request "
                    "above the cost limits without --force)",
    EXIT_BUSY: "another bkflow process is writing the same run or sweep",
    EXIT_FILE_SYSTEM: "the file system refused (permissions, full disk, a file where a "
                      "directory should be, a name too long, the directory removed while "
                      "bkflow wrote into it)",
    EXIT_RESOURCES: "out of memory, open files or file size (the machine's, or a limit set "
                    "on the process: ulimit -v, -n, -f)",
    EXIT_INTERNAL: "a bug in bkflow: one line, the traceback saved to a file it names",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C, SIGTERM, SIGHUP); the same command resumes",
    EXIT_BROKEN_PIPE: "the output's reader went away (e.g. | head)",
}


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args, **kwargs):  # no abbreviations: --over is not --overwrite
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):  # one line, exit 2 (argparse prints the usage too)
        self.exit(EXIT_BAD_INPUT, f"bkflow: error: {message}\n")


def _accuracy_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--protocol", choices=PROTOCOLS, default="steady",
                   help="steady (default): from the start that forgets fastest "
                        f"({STEADY_START}), beside a companion run from the "
                        f"{STEADY_COMPANION} start, until both are steady and agree and "
                        "mu_bar's error is below the preset's target, at most --t-end; "
                        "paper: the paper's, from the synchronized start, a fixed --t-end")
    p.add_argument("--accuracy", choices=tuple(ACCURACY), default="default",
                   help="preset of the time step, --t-end and --target-error: " + ", ".join(
                       f"{k} (the time step's bias at most {100 * c.dt_error:g}%%: dt = "
                       f"min({c.c_contact:g} / omega_c, {c.c_stable:g} / omega_max); the "
                       f"steady protocol until mu_bar's error is below {c.target_error:g}, at "
                       f"most t = {c.t_cap:g}; the paper's protocol t_end = {c.t_end:g})"
                       for k, c in ACCURACY.items()))
    p.add_argument("--t-end", type=float, default=None, metavar="T",
                   help="run length in time units (default: the --accuracy preset's); for "
                        "the steady protocol or with --target-error, the longest the run may "
                        "go (raise it if a run stops at it before it is steady)")
    p.add_argument("--dt-factor", type=float, default=None, metavar="C",
                   help="C in dt = C / omega_max, omega_max = sqrt((4 k_b + k_e + k_d + dk_d) "
                        "/ m), instead of the --accuracy preset's rule (at most "
                        f"{DT_FACTOR_MAX:g}, the stability bound)")
    p.add_argument("--target-error", type=float, default=None, metavar="E",
                   help="run until mu_bar's standard error is below this (checked every 1%% of "
                        f"--t-end, at most every {ADAPTIVE_CHUNK_T:g} time units, from t = "
                        f"{ADAPTIVE_T_MIN:g}), at most --t-end (default: the steady "
                        "protocol's preset target; none for the paper's)")


def _contact_rule_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--contact-rule", choices=CONTACT_RULES, default=RunSpec.contact_rule,
                   help="contact rule at |k_e dr| > mu_s sigma_n A: " + ", ".join(
                       f"{rule} ({what})" for rule, what in CONTACT_RULE_HELP.items()))


def _analysis_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--analysis", action="append", default=[], metavar="NAME=VALUE",
                   help="an analysis setting (repeatable): " + ", ".join(
                       f"{k}={','.join(map(str, v)) if isinstance(v, list) else v}"
                       for k, v in AnalysisSettings().to_dict().items()))


def _state_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--start", choices=STARTS, default=None,
                   help="starting state of the contacts (default: the protocol's): "
                        "synchronized (the paper's, every contact formed at t = 0), random "
                        "(each contact part-way through its cycle), stratified (the phases "
                        "evenly spread), partial (a synchronized 30%% of the contacts among "
                        "evenly spread others: the steady protocol's companion)")
    p.add_argument("--companion", choices=STARTS + ("none",), default=None,
                   help="the start of a companion run beside the run (in its companion/), "
                        "from the other side of the steady state: the run is steady only when "
                        f"both are and their mean stresses agree within "
                        f"{100 * STEADY_AGREEMENT:g}%% (default: the protocol's: "
                        f"{STEADY_COMPANION} for the steady protocol, none for the paper's)")
    p.add_argument("--until-steady", action="store_true",
                   help="with --protocol paper: run until the run is steady (the stress "
                        "trend-free, a drift above "
                        f"{100 * STEADY_DRIFT_BOUND:g}%% excluded, the contacts' phases no "
                        "longer the start's), at most --t-end; with --target-error, until "
                        "both hold (the steady protocol always does)")


#: RunSpec fields that the protocol's rule sets from options of their own (--start,
#: --companion, --t-end, ...): given with --set, they take the option's place in that rule,
#: so that every check of the option applies to them too
PROTOCOL_SETTINGS = ("start", "companion", "t_end", "dt_factor", "until_steady",
                     "target_error", "accuracy")


def _accuracy(a, settings: dict | None = None) -> dict:
    """The run's start, length rule, dt_factor and target_error: the protocol's, from the
    preset and the explicit options (bkflow.model.params.protocol_fields); ``settings`` (of --set)
    override the options they name."""
    given = {"start": a.start, "t_end": a.t_end, "dt_factor": a.dt_factor,
             "until_steady": a.until_steady, "target_error": a.target_error,
             "accuracy": a.accuracy,
             "companion": "" if a.companion is None else None if a.companion == "none"
             else a.companion}
    given.update(settings or {})
    if a.protocol == "steady" and (settings or {}).get("until_steady") is False:
        raise SpecError("until_steady=false under the steady protocol, which runs until the "
                        "run is steady: for a fixed length give --protocol paper (with --start "
                        "and --companion as wanted)")
    accuracy = given.pop("accuracy")
    return protocol_fields(a.protocol, accuracy, **given)


def _set_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="any other model or run parameter (repeatable), e.g. --set gamma=0.1 "
                        "--set V_d=0.05; it overrides the options above. Parameters: "
                        + ", ".join(f"{f}={getattr(RunSpec, f, None)}" for f in
                                    RunSpec.__dataclass_fields__
                                    if f not in RunSpec.OWN_OPTIONS))


def _spec_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--phi", type=float, required=True, metavar="PHI", help="k_b / dk_d (> 0)")
    size = p.add_mutually_exclusive_group()
    size.add_argument("--size", metavar="LXxLY",
                      help=f"lattice LXxLY (default {RunSpec.Lx}x{RunSpec.Ly})")
    size.add_argument("--n", type=int, help="the paper's sizes: " + ", ".join(
        f"{n} ({lx}x{ly})" for n, (lx, ly) in PAPER_SIZES.items()))
    _accuracy_args(p)
    _state_args(p)
    p.add_argument("--seed", type=int, default=RunSpec.seed, metavar="S",
                   help="seed of the k_d^i draw")
    _contact_rule_arg(p)
    p.add_argument("--scene", choices=SCENES, default=RunSpec.scene,
                   help="what to record: friction (sigma_x's turning points and block sums of "
                        "the stress and the contacts' phases, reduced in the run), series (+ "
                        "the raw stress and phase series), order (+ Psi(t), in the run), "
                        "clusters (+ positions at each slip), figures (default: order and "
                        "clusters, what the table and the figures show), events (clusters + "
                        "the energy ledger and each slip's first breaks: the event "
                        "catalogue), fronts (+ every particle's slip rate through every "
                        "slip), full (all; the fronts of the first slips only)")
    _set_arg(p)
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")


def _spec(a, deck: bool = False) -> RunSpec:
    """The RunSpec of ``bkflow run`` (or, ``deck``, of ``bkflow deck``: a deck runs a fixed
    length, so the steady protocol writes its start with the preset's fixed t_end, and the
    analysis of the standalone run says whether it was steady)."""
    if not str(a.out).strip():
        raise SpecError("--out is empty: name the run directory")
    if a.n is not None:
        Lx, Ly = size_from_n(a.n)
    elif a.size is not None:
        Lx, Ly = parse_size(a.size)
    else:
        Lx, Ly = RunSpec.Lx, RunSpec.Ly
    sets = RunSpec.assignments(a.set)
    routed = {k: sets.pop(k) for k in PROTOCOL_SETTINGS if k in sets}
    fields = {"contact_rule": a.contact_rule, "scene": a.scene, **_accuracy(a, routed)}
    if deck and a.protocol == "steady" and not (a.until_steady or routed.get("until_steady")):
        accuracy = routed.get("accuracy", a.accuracy)
        t_end = routed.get("t_end", a.t_end)
        fields.update(until_steady=False, companion=routed.get(
                          "companion", None if a.companion in (None, "none") else a.companion),
                      target_error=routed.get("target_error", a.target_error),
                      t_end=ACCURACY[accuracy].t_end if t_end is None else t_end)
    fields.update(sets)
    return RunSpec(phi=a.phi, Lx=Lx, Ly=Ly, seed=a.seed, **fields)


def _path_arg(p) -> None:
    p.add_argument("--path", choices=PATHS, default="auto",
                   help="integration path: auto (default: the fused path whenever the lattice "
                        "is bkflow's, on any number of ranks; else the general path), general "
                        "(fix nve + fix bk/substrate + fix enforce2d, as before the fused path: "
                        "slower, same physics), fused (refuses what it cannot run)")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="bkflow", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"bkflow {__version__}")
    sub = p.add_subparsers(dest="cmd", required=True, parser_class=_Parser)
    r = sub.add_parser("run", help=f"run the model: writes {rd.DECK}, {rd.DATA}, {rd.EXTREMA}, "
                                   f"{rd.BLOCKS}, {rd.META} (and what the scene asks for)")
    _spec_args(r)
    r.add_argument("--overwrite", action="store_true", help="redo a finished run in --out")
    r.add_argument("--force", action="store_true",
                   help="run even above the cost limits (work, memory, disk; bkflow.lammps.limits)")
    r.add_argument("--quiet", action="store_true", help="no progress line")
    r.add_argument("--no-analyze", action="store_true",
                   help=f"skip the analysis ({rd.SUMMARY}); run bkflow analyze DIR later")
    _path_arg(r)
    d = sub.add_parser("deck", help=f"write {rd.DECK}, {rd.DATA}, {rd.PARAMS} without running "
                                    f"(lmp -in {rd.DECK})")
    _spec_args(d)
    _path_arg(d)
    sw = sub.add_parser("sweep", help="run a grid of phi x sizes x seeds in parallel "
                                      "(signac-flow); re-running skips finished runs")
    sw.add_argument("--phi", required=True, metavar="A:B|a,b,c",
                    help="range A:B (log-spaced, --points-per-decade per decade) or list a,b,c")
    sw.add_argument("--points-per-decade", type=int, default=POINTS_PER_DECADE, metavar="K",
                    help=f"phi values per decade of a range (default {POINTS_PER_DECADE})")
    sw.add_argument("--sizes", default=f"{RunSpec.Lx}x{RunSpec.Ly}", metavar="LXxLY,...",
                    help="lattices LXxLY[,LXxLY...] or the paper's N ("
                         + ",".join(map(str, PAPER_SIZES))
                         + f"); default {RunSpec.Lx}x{RunSpec.Ly}")
    sw.add_argument("--aspect", default=None, metavar="R|any",
                    help=f"Lx/Ly every size must have (default {ASPECT}, the paper's), or 'any'")
    sw.add_argument("--seeds", type=int, default=SEEDS, metavar="K",
                    help=f"seeds 1..K per (phi, size) (default {SEEDS})")
    _accuracy_args(sw)
    _state_args(sw)
    _contact_rule_arg(sw)
    _analysis_arg(sw)
    sw.add_argument("--scene", choices=SCENES, default=RunSpec.scene,
                    help="what each run records (as bkflow run --scene; default figures: what "
                         "the table and the figures show)")
    _set_arg(sw)
    sw.add_argument("--vary", action="append", default=[], metavar="NAME=V1,V2,...",
                    help="another axis of the grid (repeatable): any parameter --set takes, "
                         "e.g. --vary gamma=0.05,0.1,0.2; every combination is run")
    sw.add_argument("--jobs", type=int, default=None, metavar="J",
                    help="runs at a time, one process each (default: all cores)")
    sw.add_argument("--out", default="runs/sweep", metavar="DIR",
                    help="sweep directory (default runs/sweep)")
    sw.add_argument("--quiet", action="store_true", help="no progress output")
    sw.add_argument("--force", action="store_true",
                    help="run even above the limits (runs, processes, work, memory, disk)")
    sw.add_argument("--init", action="store_true",
                    help="only create the jobs (for workflows/project.py submit); run nothing")
    co = sub.add_parser("collect", help="re-analyse what is stale, (re)write the tables from the "
                                        "finished runs of a sweep directory")
    co.add_argument("dir", help="sweep directory")
    _analysis_arg(co)
    pl = sub.add_parser("plot", help="the paper's figures from a sweep directory (PNG + PDF)")
    pl.add_argument("dir", help="sweep directory (bkflow sweep --out DIR)")
    pl.add_argument("--out", default=None, help="figure directory (default DIR/figures)")
    pl.add_argument("--format", default="png,pdf", help="comma-separated formats (default png,pdf)")
    pl.add_argument("--where", action="append", default=[], metavar="COLUMN=VALUE",
                    help="plot only the runs with this parameter value (repeatable), e.g. "
                         "t_end=16000 or start=random, when the directory holds several sweeps")
    an = sub.add_parser("analyze", help=f"analyse a finished run: writes DIR/{rd.SUMMARY}, "
                                        f"{rd.EVENTS_PARQUET} (+ {rd.PSI}, {rd.CLUSTERS})")
    an.add_argument("dir", help=f"run directory (written by bkflow run or lmp -in {rd.DECK})")
    _analysis_arg(an)
    mv = sub.add_parser("movie", help="a rupture front: an animated GIF of one slip (the layer "
                                      "coloured by slip rate) and its x-t / y-t maps (PNG); "
                                      "needs a run with --scene fronts or full")
    mv.add_argument("dir", help="run directory")
    mv.add_argument("--slip", type=int, default=0,
                    help="which recorded slip (0 = the first after the transient; default 0)")
    mv.add_argument("--out", default=None,
                    help="the GIF (default DIR/movie_slip<K>.gif; the maps go beside it as "
                         "fronts_slip<K>.png)")
    mv.add_argument("--fps", type=float, default=15.0, help="frames per second (default 15)")
    return p


def subcommands(parser: argparse.ArgumentParser | None = None) -> dict:
    """{name: parser} of bkflow's commands."""
    parser = parser or build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def synopsis(command: str, width: int = 96) -> str:
    """The usage of ``bkflow COMMAND`` with every option, as argparse writes it, wrapped to
    ``width``: the synopses of the README (tests/test_readme.py keeps them equal)."""
    p = subcommands()[command]
    formatter = argparse.HelpFormatter(p.prog, width=width)
    formatter.add_usage(p.usage, p._actions, p._mutually_exclusive_groups, prefix="")
    return formatter.format_help().rstrip()


def _sweep(a) -> int:
    from bkflow.store.tables import RESULTS_FILE, RUNS_FILE, rows_of
    from bkflow.sweeps.grid import parse_aspect, parse_sizes, phi_values, sweep_specs
    from bkflow.sweeps.local import available_cores, fmt_duration, sweep

    phis = phi_values(a.phi, a.points_per_decade)
    sizes = parse_sizes(a.sizes, parse_aspect(a.aspect))
    if a.jobs is not None and a.jobs < 1:
        raise SpecError(f"--jobs must be >= 1, got {a.jobs}")
    sets = RunSpec.assignments(a.set)
    axes = RunSpec.variations(a.vary)
    both = set(axes) & set(sets)
    if both:
        raise SpecError(f"--vary and --set both give {', '.join(sorted(both))}: choose one")
    routed = {k: sets.pop(k) for k in PROTOCOL_SETTINGS if k in sets}

    def fields(extra: dict) -> dict:
        """A grid point's fields: the protocol's rule fed by --set and this point's --vary
        values of the settings it takes (start, companion, t_end, ...), as the options."""
        own = {k: v for k, v in extra.items() if k in PROTOCOL_SETTINGS}
        return {"contact_rule": a.contact_rule, "scene": a.scene,
                **_accuracy(a, {**routed, **own}), **sets}
    from bkflow.lammps.limits import check_run_count, check_sweep

    check_run_count(math.prod([len(phis), len(sizes), a.seeds, *map(len, axes.values())]),
                    a.force)
    specs = sweep_specs(phis, sizes, a.seeds, axes=axes, fields=fields)
    settings = AnalysisSettings().with_assignments(a.analysis) if a.analysis else None
    jobs = a.jobs or available_cores()
    from bkflow.sweeps.project import check_sweep_dir

    check_sweep_dir(a.out)
    total = check_sweep(specs, a.out, jobs, available_cores(), a.force)
    if a.init:
        from bkflow.sweeps.project import init_jobs

        done = init_jobs(specs, a.out, settings, force=a.force)
        where = shell_word(a.out)
        print(f"{a.out}: {len(specs)} jobs ({done} finished); run them here with\n"
              f"  (cd {where} && python -m bkflow.cluster run)\n"
              f"or submit them to the cluster's scheduler with\n"
              f"  (cd {where} && python -m bkflow.cluster submit)")
        return 0
    extra = "".join(f" x {len(v)} {k}" for k, v in axes.items())
    print(f"sweep: {len(phis)} phi x {len(sizes)} size(s){extra} x {a.seeds} seed(s) = "
          f"{len(specs)} runs into {a.out}, {jobs} at a time", flush=True)
    print(f"  phi = {', '.join(f'{p:g}' for p in phis)}", flush=True)
    print("  " + report.cost_line(total, jobs, any(s.adaptive for s in specs)), flush=True)
    for k, v in axes.items():
        print(f"  {k} = {', '.join(map(str, v))}", flush=True)
    rep = sweep(specs, a.out, jobs=jobs, progress=False if a.quiet else None,
                settings=settings, force=a.force)
    print(f"{len(rep.finished)} run(s) done in {fmt_duration(rep.wall_time_s)}, "
          f"{rep.finished_before} finished earlier (skipped), {len(rep.failed)} failed"
          + (f" ({len(rep.reanalysed)} of them only re-analysed)" if rep.reanalysed else "")
          + (f", {len(rep.unfinished)} not finished" if rep.unfinished else "")
          + (f" ({len(rep.busy)} of them written by another process)" if rep.busy else ""))
    res = rep.results
    if len(res):  # this sweep's rows (the directory may hold other sweeps too)
        res = rows_of(res, specs)
        print("\n".join(report.results_lines(res, list(axes))))
    if len(res):
        print(report.states_line(res))
    print(f"wrote {a.out}/{RUNS_FILE} and {a.out}/{RESULTS_FILE}; figures: bkflow plot "
          f"{shell_word(a.out)}")
    _say_retired(a.out, rep.retired_figures)
    for job_id, msg in rep.failed.items():
        what = "refused" if job_id in rep.refused else "run failed"
        print(f"bkflow: {what}: {msg} (job {job_id})", file=sys.stderr)
    if rep.busy and not rep.failed and len(rep.busy) == len(rep.unfinished):
        print(f"bkflow: busy: {len(rep.busy)} run(s) are being written by another process "
              "(e.g. python -m bkflow.cluster run); run the same command once it is done",
              file=sys.stderr)
        return EXIT_BUSY
    if rep.refused and len(rep.refused) == len(rep.failed) and not rep.unfinished:
        print(f"bkflow: {len(rep.refused)} run(s) refused: their directories hold what bkflow "
              "does not replace or read (the lines above name it); move that away, then the "
              "same command runs them", file=sys.stderr)
        return EXIT_BAD_INPUT
    if rep.failed or rep.unfinished:
        print(f"bkflow: {len(rep.failed) + len(rep.unfinished)} run(s) did not finish; the "
              "same command retries them"
              + (f" ({len(rep.refused)} of them refused: move away what the lines above name)"
                 if rep.refused else ""), file=sys.stderr)
        return EXIT_RUN_FAILED
    return 0


def _say_retired(root, removed) -> None:
    if removed:
        print(f"removed {len(removed)} figure file(s) of {root}/figures drawn from the tables "
              "before (they no longer match them): bkflow plot "
              f"{shell_word(root)} draws them again")


def _collect(a) -> int:
    from bkflow.store.tables import RESULTS_FILE, RUNS_FILE
    from bkflow.sweeps.local import collect
    from bkflow.sweeps.project import open_project

    try:
        project = open_project(a.dir, create=False)
    except FileNotFoundError as exc:
        print(f"bkflow: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    settings = AnalysisSettings().with_assignments(a.analysis) if a.analysis else None
    c = collect(project, settings)
    print(f"{a.dir}: {c.jobs} jobs, {c.finished} finished, {len(c.failed)} failed, "
          f"{c.jobs - c.finished - len(c.failed)} not run; {len(c.reanalysed)} re-analysed")
    if len(c.results):
        from bkflow.store.tables import varied_parameters

        print("\n".join(report.results_lines(c.results, varied_parameters(c.results))))
        print(report.states_line(c.results))
    print(f"wrote {a.dir}/{RUNS_FILE} ({len(c.runs)} rows) and {a.dir}/{RESULTS_FILE} "
          f"({len(c.results)} rows)")
    _say_retired(a.dir, c.retired_figures)
    for j in c.failed:
        print(f"  failed {j.id}: {j.document['error']}", file=sys.stderr)
    for job_id, why in c.damaged:
        print(f"bkflow: warning: run {job_id} is damaged ({why}) and left out of the tables: "
              f"collect does not run LAMMPS; the sweep's own command (bkflow sweep ... --out "
              f"{shell_word(a.dir)}) runs it again", file=sys.stderr)
    return 0


def _plot(a) -> int:
    from bkflow.figures.plot import PlotError, parse_where, plot

    try:
        paths, skipped = plot(a.dir, a.out, tuple(f.strip() for f in a.format.split(",")),
                              parse_where(a.where))
    except PlotError as exc:
        print(f"bkflow: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    for p in paths:
        print(f"wrote {p}")
    for name, why in skipped.items():
        print(f"skipped {name}: {why}")
    return 0


def _movie(a) -> int:
    from pathlib import Path

    from bkflow.api import Run
    from bkflow.figures.plot import STYLE, PlotError
    from bkflow.store.rundir import AnalysisError

    if not 0.1 <= a.fps <= 50:
        raise SpecError(f"--fps must lie in [0.1, 50] (a GIF shows a frame for at least "
                        f"20 ms), got {a.fps:g}")
    if a.slip < 0:
        raise SpecError(f"--slip must be >= 0 (the recorded slips count from 0), got {a.slip}")
    from bkflow.store.rundir import DamagedRunError

    try:
        run = Run(a.dir)
        fronts = run.fronts
    except (AnalysisError, DamagedRunError) as exc:
        print(f"bkflow: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    out = Path(a.out) if a.out else rd.RunDir(a.dir).movie_file(a.slip)
    if out.suffix.lower() != ".gif":
        raise SpecError(f"--out {out}: bkflow writes GIF movies (name it .gif)")
    from bkflow.store.formats import foreign_file

    maps = out.parent / rd.FRONT_MAPS_PATTERN.format(a.slip)
    if not out.parent.is_dir():
        raise SpecError(f"--out {out}: the directory {out.parent} does not exist")
    for p in (out, maps):  # a user's file of the same name is never replaced
        why = foreign_file(p)
        if why is not None:
            raise SpecError(why)
    try:
        fig = run.front_figure(a.slip)
        path = run.movie(a.slip, out, a.fps)
    except PlotError as exc:
        print(f"bkflow: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    from bkflow.store.formats import MARK, atomic_file

    with atomic_file(maps, binary=True) as fh:
        fig.savefig(fh, format=maps.suffix[1:], dpi=STYLE["savefig.dpi"], bbox_inches="tight",
                    metadata={"Creator": MARK})
    f = fronts[a.slip]
    print(f"wrote {path} ({len(f.steps)} frames, t = {f.step_max * run.spec.dt:g} to "
          f"{f.step_min * run.spec.dt:g}) and {maps}")
    return 0


def _run(a, argv) -> int:
    from bkflow.lammps.limits import check_cost
    from bkflow.store.rundir import RunDir

    spec = _spec(a)
    resumes_analysis = (not a.overwrite and not a.no_analyze
                        and RunDir(a.out).only_analysis_left(spec))
    if not resumes_analysis:  # (a finished run's analysis writes little: no estimate)
        check_cost(spec, a.out, a.force)  # before anything is created
    why = RunDir(a.out).foreign()
    if why is not None:  # refused before a lock file is left in someone else's directory
        raise SpecError(f"{a.out} {why}: bkflow writes only into an empty directory or its "
                        "own run; choose another --out")
    with RunDir(a.out).lock():  # the run and its analysis: one writer from start to end
        return _run_locked(a, argv, spec)


def _run_locked(a, argv, spec) -> int:
    from bkflow.lammps.engine import run
    from bkflow.store.rundir import RunDir

    if not a.overwrite and not a.no_analyze and RunDir(a.out).only_analysis_left(spec):
        # the same command again after its analysis was cut short
        from bkflow.analysis.summary import analyze

        print(f"{a.out}: this run finished earlier; analysing it")
        _print_summary(analyze(a.out))
        return 0
    res = run(spec, a.out, overwrite=a.overwrite, progress=None if not a.quiet else False,
              command="bkflow " + shlex.join(argv), force=a.force, path=a.path)
    m = res.meta
    eng = m["engine"]
    pair = " (and as many for its companion)" if m.get("companion") else ""
    print(f"{a.out}: {m['derived']['n_steps']} steps{pair} in {m['wall_time_s']:.1f} s "
          f"({m['atom_steps_per_s']:.3g} atom-steps/s, {eng['path']} path"
          + (f", {eng['kernel']} kernel" if eng["kernel"] else "")
          + f"), {m['contact_breaks']} contact breaks")
    ad = m.get("adaptive")
    if ad:
        print("  adaptive: " + report.stop_line(ad, spec.companion)
              + ("" if ad["reached"] else "; raise --t-end"))
    if not a.no_analyze:
        from bkflow.analysis.summary import analyze

        try:
            summary = analyze(a.out)
        except KeyboardInterrupt:
            print(f"{_NL()}bkflow: interrupted during the analysis; the run itself is finished: "
                  f"bkflow analyze {shell_word(a.out)} (or the same command) analyses it",
                  file=sys.stderr)
            return EXIT_INTERRUPTED
        _print_summary(summary)
    return 0


def _analyze(a) -> int:
    from bkflow.analysis.summary import analyze
    from bkflow.store.rundir import RunDir

    settings = AnalysisSettings().with_assignments(a.analysis)
    d = RunDir(a.dir)
    why = d.analysis_problem(settings) if d.is_complete() and d.problem() is None else None
    summary = analyze(a.dir, settings)
    print(f"{a.dir}/{rd.SUMMARY} written"
          + (f" (re-analysed: {why})" if why and not why.startswith("no ") else ""))
    _print_summary(summary)
    return 0


def _deck(a) -> int:
    from bkflow.lammps.deck import DeckOptions, write_deck, written_by_bkflow
    from bkflow.store.rundir import RunDir

    spec = _spec(a, deck=True)
    if spec.adaptive:
        raise SpecError("an adaptive run (--until-steady, --target-error) needs the engine, "
                        "which checks between chunks (bkflow run); a deck runs exactly "
                        "--t-end")
    if spec.companion is not None:
        raise SpecError(f"companion {spec.companion} (--companion or --set): a deck is one run, "
                        "and a companion is a second run beside it, which bkflow run runs; "
                        f"write the companion's own deck with --start {spec.companion} --out "
                        "ANOTHER_DIR")
    d = RunDir(a.out)
    made = rd.META if d.meta() is not None else next(
        (n for n in (rd.EXTREMA, rd.STRESS) if d.file(n).exists()), None)
    if made is not None:
        raise SpecError(f"{a.out} holds a run ({made}); a deck is written only into an empty "
                        "directory or over a deck: choose another --out")
    why = d.foreign()
    if why is not None and not why.startswith("holds a deck"):
        raise SpecError(f"{a.out} {why}: choose another --out")
    for name in (rd.DECK, rd.DATA, rd.PARAMS):  # replace only what bkflow deck wrote
        if d.file(name).exists() and not written_by_bkflow(d.file(name)):
            raise SpecError(f"{d.file(name)} was not written by bkflow deck, or was edited "
                            "since (its signature does not match): bkflow replaces only its "
                            "own decks; choose another --out")
    paths = write_deck(spec, a.out, DeckOptions(path=a.path))
    print(f"wrote {paths['deck']} and {paths['data']} ({spec.n_steps} steps)")
    return 0


def _print_summary(s: dict) -> None:
    print("\n".join(report.summary_lines(s)))


def _fs_message(exc: OSError) -> str:
    where = f"{exc.filename}: " if exc.filename else ""
    return f"{where}{exc.strerror or exc}"


def main(argv=None) -> int:
    """The command line; returns the exit code (``EXIT_CODES``). SIGTERM and SIGHUP
    (a closed terminal) are taken as Ctrl-C: the command stops within a second, keeps what is
    finished, and the same command resumes; one started with it ignored (``nohup``) keeps
    ignoring it."""
    import signal

    from bkflow.lammps import plugin

    # a signal this process was started with ignored stays ignored (nohup: SIGHUP)
    plugin.INTERRUPT_SIGNALS = tuple(s for s in (signal.SIGTERM, signal.SIGHUP)
                                     if signal.getsignal(s) != signal.SIG_IGN)
    plugin.restore_signals()
    short = _process_limit_short()
    if short is not None:
        print(f"bkflow: {short}: raise the limit", file=sys.stderr)
        return EXIT_RESOURCES
    for name in ("stdout", "stderr"):  # closed by the caller (2>&-): write into the void
        if getattr(sys, name) is None:
            setattr(sys, name, open(os.devnull, "w"))  # noqa: SIM115 (for the process' life)
    try:
        return _main(argv)
    except KeyboardInterrupt:  # before a command started (while Python imports)
        print(f"{_NL()}bkflow: interrupted before anything was written", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # the reader of our output went away (| head): say nothing more
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except ImportError as exc:  # a library that cannot be mapped into memory is out of it
        if "failed to map segment" not in str(exc) and "Cannot allocate" not in str(exc):
            return _internal_error()
        return _out_of_memory()
    except MemoryError:
        return _out_of_memory()
    except Exception:  # a bug: one line, and the traceback where it can be reported from
        return _internal_error()


#: the process limits below which MPI, LAMMPS or the libraries under bkflow end the process
#: from C (UCX or MPICH aborts, exit 134 or 143; the BLAS under SciPy exits 1 when it cannot
#: allocate its buffers under ~320 MB): resource, ulimit option, minimum, unit (bytes), what
PROCESS_LIMITS = (
    ("RLIMIT_AS", "-v", 512, 2**20, "out of memory: this process may use at most {have} MB "
     "(ulimit -v, or the job's limit); bkflow needs at least {need} MB to load its libraries"),
    ("RLIMIT_NOFILE", "-n", 64, 1, "error: this process may open at most {have} files "
     "(ulimit -n); MPI and LAMMPS need at least {need}"),
    ("RLIMIT_FSIZE", "-f", 64, 2**20, "error: this process may write files of at most {have} "
     "MB (ulimit -f); MPI's shared memory needs {need} MB, and a run's series more"),
)


def _process_limit_short() -> str | None:
    """The first process limit (``PROCESS_LIMITS``) below what bkflow needs, said."""
    import resource

    for name, _, need, unit, said in PROCESS_LIMITS:
        soft, _ = resource.getrlimit(getattr(resource, name))
        if soft != resource.RLIM_INFINITY and soft / unit < need:
            return said.format(have=f"{soft / unit:.3g}", need=need)
    return None


def _out_of_memory() -> int:
    print("bkflow: out of memory: this machine (or its limit, ulimit -v or the job's) "
          "cannot hold what the command needs; nothing finished was changed: free "
          "memory, raise the limit, or ask for a smaller run", file=sys.stderr)
    return EXIT_RESOURCES


def _internal_error() -> int:
    import tempfile
    import traceback

    text = traceback.format_exc()
    try:
        fd, path = tempfile.mkstemp(prefix="bkflow-error-", suffix=".txt")
        with os.fdopen(fd, "w", errors="backslashreplace") as f:
            f.write(f"bkflow {__version__}: {' '.join(sys.argv)}\n{text}")
        where = f"the traceback is in {path}"
    except OSError:
        where = "the traceback could not be saved"
    last = text.strip().splitlines()[-1]
    print(f"bkflow: internal error ({last}); {where}: please report it with the command "
          "that caused it; nothing finished was changed", file=sys.stderr)
    return EXIT_INTERNAL


def _NL() -> str:  # noqa: N802
    """A newline to end a progress line on a terminal; nothing elsewhere (one line)."""
    try:
        return "\n" if sys.stderr.isatty() else ""
    except (AttributeError, ValueError):
        return ""


def _thread_count(text: str) -> bool:
    return text.strip().isdigit() and int(text) > 0


def check_environment(env=os.environ) -> None:
    """The environment variables the libraries under bkflow read, checked before any of them
    is imported, so that a bad one is named (it was reported as a damaged stress.csv when
    numexpr, under pandas, failed to read OMP_NUM_THREADS). Adjusts what the command line does
    not need: figures are written to files (matplotlib's Agg backend, whatever MPLBACKEND
    says), and a local run or sweep submits nothing (flow's SIGNAC_FLOW_ENVIRONMENT is for
    python -m bkflow.cluster)."""
    for var in ("NUMEXPR_MAX_THREADS", "NUMEXPR_NUM_THREADS"):
        v = env.get(var, "")
        if v and not _thread_count(v):
            raise SpecError(f"environment variable {var}={v!r} is not a number of threads "
                            "(numexpr, under pandas, reads it): unset it or give an integer")
    omp = env.get("OMP_NUM_THREADS", "")
    if omp:
        if not all(_thread_count(n) for n in omp.split(",")):
            raise SpecError(f"environment variable OMP_NUM_THREADS={omp!r} is not an OpenMP "
                            "thread count (e.g. 4, or 4,2 for nested levels): unset it or fix it")
        if "," in omp and not env.get("NUMEXPR_NUM_THREADS"):
            env["NUMEXPR_NUM_THREADS"] = omp.split(",")[0].strip()  # numexpr reads one level
    env["MPLBACKEND"] = "Agg"
    env.pop("SIGNAC_FLOW_ENVIRONMENT", None)
    bad = [k for k in env if k.startswith("TQDM_")]
    if bad:
        try:
            from tqdm import tqdm

            tqdm(total=1, disable=True).close()
        except Exception as exc:
            raise SpecError(f"environment variable {', '.join(sorted(bad))}: tqdm (the progress "
                            f"bars) cannot read it ({exc}): unset it or fix it") from None


def _main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    from bkflow.lammps.limits import mpi_refusal

    why = mpi_refusal()
    if why:  # before anything, --help and --version included: one line a copy
        print(f"bkflow: error: {why}", file=sys.stderr)
        return EXIT_BAD_INPUT
    a = build_parser().parse_args(argv)
    paths = [p for p in (getattr(a, "out", None), getattr(a, "dir", None)) if p]
    for p in paths:
        try:
            str(p).encode("utf-8")
        except UnicodeEncodeError:
            print(f"bkflow: error: {os.fsencode(str(p))!r} is not a UTF-8 name: bkflow's "
                  "tables and records (JSON, CSV) need one; choose another", file=sys.stderr)
            return EXIT_BAD_INPUT
    try:
        os.getcwd()
    except FileNotFoundError:
        if not paths or not all(os.path.isabs(str(p)) for p in paths):
            print("bkflow: error: the current directory no longer exists (deleted while this "
                  "shell stood in it): cd to an existing directory, or give absolute paths",
                  file=sys.stderr)
            return EXIT_FILE_SYSTEM
        os.chdir("/")  # every path is absolute: the lost directory is not needed
    try:
        check_environment()
    except SpecError as exc:
        print(f"bkflow: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    from bkflow.lammps.engine import RunDiskError, RunError, RunExistsError
    from bkflow.lammps.plugin import PluginError
    from bkflow.store.formats import NotRegularFileError, OutsideError
    from bkflow.store.rundir import AnalysisError, DamagedRunError, RunBusyError

    commands = {"analyze": _analyze, "sweep": _sweep, "plot": _plot, "collect": _collect,
                "movie": _movie,
                "deck": _deck}
    try:
        if a.cmd == "run":
            return _run(a, argv)
        return commands[a.cmd](a)
    except NotRegularFileError as exc:
        print(f"bkflow: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (AnalysisError, DamagedRunError) as exc:
        target = a.dir if a.cmd == "analyze" else a.out if a.cmd == "run" else None
        text = " ".join(str(exc).splitlines())
        named = target is not None and any(
            text.startswith(str(p)) for p in (target, Path(target).absolute(),
                                              Path(target).resolve()))
        where = f"cannot analyse {target}: " if target is not None and not named else ""
        print(f"bkflow: error: {where}{text}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (SpecError, RunExistsError, PluginError, OutsideError) as exc:
        print(f"bkflow: error: {' '.join(str(exc).splitlines())}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except RunBusyError as exc:
        print(f"bkflow: busy: {exc}", file=sys.stderr)
        return EXIT_BUSY
    except RunDiskError as exc:
        print(f"bkflow: file system: {exc}", file=sys.stderr)
        return EXIT_FILE_SYSTEM
    except RunError as exc:
        print(f"bkflow: run failed: {exc}", file=sys.stderr)
        return EXIT_RUN_FAILED
    except FileNotFoundError as exc:
        out = getattr(a, "out", None) if a.cmd in ("run", "sweep") else None
        missing = Path(str(exc.filename or "")).absolute()
        if out is not None and not Path(out).exists() and \
                Path(out).absolute() in (missing, *missing.parents):   # removed under it
            print(f"bkflow: file system: {out} was removed while bkflow wrote into it; the "
                  "same command starts it again", file=sys.stderr)
            return EXIT_FILE_SYSTEM
        print(f"bkflow: error: {_fs_message(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        raise
    except OSError as exc:  # permissions, a full disk, a name too long, a file for a directory
        print(f"bkflow: file system: {_fs_message(exc)}; nothing finished was changed",
              file=sys.stderr)
        return EXIT_FILE_SYSTEM
    except KeyboardInterrupt:
        what = ("finished runs are kept, an interrupted one is redone" if a.cmd in ("run",
                "sweep") else "what was written is whole, the rest unchanged")
        print(f"{_NL()}bkflow: interrupted; {what}: run the same command again to resume",
              file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    raise SystemExit(main())
