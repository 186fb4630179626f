"""bkflow: Burridge-Knopoff friction (Giacco et al. 2014) on LAMMPS, from one run to a sweep.

The commands: ``bkflow run``, ``sweep``, ``plot``, ``analyze``, ``collect``, ``deck`` and
``movie``, each a small function of the parsed arguments (``bkflow.cli.parser``) that calls
the package and prints what ``bkflow.cli.report`` words.

Every expected failure is one line on stderr and an exit code of ``EXIT_CODES``
(``bkflow.cli.guards``): bad input 2, a failed run 1, another process busy 3, the file system
4. Nothing half-written is left looking complete: a run directory counts as finished only
once its meta.json says so.
"""

from __future__ import annotations

import math
import os
import shlex
import sys

# every bkflow process is one single-threaded run (a sweep runs one process per core): the
# idle threads of NumPy's OpenBLAS spin, and on a small machine they steal LAMMPS's core
# (5% of a run's samples at N = 900 in perf). Set before NumPy loads; a user's value wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from bkflow.cli import guards, report, stops  # noqa: E402
from bkflow.cli.assignments import (  # noqa: E402
    analysis_assignments,
    parse_aspect,
    parse_sizes,
    parse_where,
    run_assignments,
    run_variations,
)
from bkflow.cli.guards import (  # noqa: E402
    EXIT_BAD_INPUT,
    EXIT_BUSY,
    EXIT_INTERRUPTED,
    EXIT_RUN_FAILED,
)
from bkflow.cli.parser import (  # noqa: E402
    PROTOCOL_SETTINGS,
    build_parser,
    option_fields,
    run_spec,
)
from bkflow.model.checks import SpecError  # noqa: E402
from bkflow.model.settings import AnalysisSettings  # noqa: E402
from bkflow.store import errors, layout  # noqa: E402
from bkflow.store import rundir as rd  # noqa: E402
from bkflow.store.files import shell_word  # noqa: E402


# ------------------------------------------------------------------------- a run
def _run(a, argv) -> int:
    from bkflow.lammps.engine import claim

    spec = run_spec(a)
    resumes_analysis = (not a.overwrite and not a.no_analyze
                        and rd.RunDir(a.out).only_analysis_left(
                            spec, rd.RunDir(a.out).kept_settings()))
    # the run and its analysis: one writer from start to end (an analysis resumed runs
    # nothing: no estimate)
    with claim(a.out, None if resumes_analysis else spec, a.overwrite, a.force):
        return _run_locked(a, argv, spec)


def _run_locked(a, argv, spec) -> int:
    from bkflow.lammps.engine import run

    # the settings of the run's last analysis (bkflow analyze --analysis ...), which the same
    # run command keeps: it does not name settings, and never drops them silently
    kept = rd.RunDir(a.out).kept_settings() if not a.overwrite else AnalysisSettings()
    if not a.overwrite and not a.no_analyze and rd.RunDir(a.out).only_analysis_left(spec,
                                                                                   kept):
        # the same command again after its analysis was cut short
        from bkflow.analysis.summary import analyze

        print(report.analysing_again_line(a.out))
        report.print_summary(analyze(a.out, kept))
        return 0
    res = run(spec, a.out, overwrite=a.overwrite, progress=None if not a.quiet else False,
              command="bkflow " + shlex.join(argv), force=a.force, path=a.path)
    if not res.ran:
        print(stops.answered_line(a.out, res.meta, spec.t_end))
        return 0 if a.no_analyze else _analyze_run(a.out, kept)
    print(report.run_line(a.out, res.meta))
    if res.meta.get("adaptive"):
        print("\n".join(stops.adaptive_lines(res.meta["adaptive"], spec.companion,
                                               res.meta.get("command"),
                                               res.meta.get("atom_steps_per_s"))))
    return 0 if a.no_analyze else _analyze_run(a.out, kept)


def _analyze_run(out, settings: AnalysisSettings) -> int:
    """The analysis of the run ``bkflow run`` just finished, printed, under ``settings`` (its
    last analysis's, said where they are not the defaults)."""
    from bkflow.analysis.summary import analyze

    spec = rd.RunDir(out).spec()
    if settings.resolved(spec) != AnalysisSettings().resolved(spec):
        changed = {k: v for k, v in settings.resolved(spec).to_dict().items()
                   if AnalysisSettings().resolved(spec).to_dict()[k] != v}
        print("  analysed under the settings of its last analysis ("
              + ", ".join(f"{k}={v}" for k, v in changed.items())
              + f"); bkflow analyze {shell_word(out)} analyses it under the defaults")
    try:
        summary = analyze(out, settings)
    except KeyboardInterrupt:
        guards.say(f"{guards.progress_newline()}bkflow: interrupted during the analysis; the "
                   f"run itself is finished: bkflow analyze {shell_word(out)} (or the same "
                   "command) analyses it")
        return EXIT_INTERRUPTED
    report.print_summary(summary)
    return 0


def _analyze(a) -> int:
    from bkflow.analysis.summary import analyze

    settings = analysis_assignments(a.analysis)
    d = rd.RunDir(a.dir)
    why = d.analysis_problem(settings) if d.is_complete() and d.problem() is None else None
    summary = analyze(a.dir, settings)
    print(report.analysed_line(a.dir, why))
    report.print_summary(summary)
    return 0


def _deck(a) -> int:
    from bkflow.lammps.deck import DeckOptions
    from bkflow.lammps.deckfiles import check_deck_target, write_deck

    spec = run_spec(a, deck=True)
    check_deck_target(spec, rd.RunDir(a.out), a.out)
    paths = write_deck(spec, a.out, DeckOptions(path=a.path))
    print(report.deck_line(paths, spec.n_steps))
    return 0


# ------------------------------------------------------------------------- a sweep
def _sweep_specs(a) -> tuple:
    """The sweep's grid: (phi values, sizes, --vary axes, every run's RunSpec), checked and
    within the limit on the number of runs."""
    from bkflow.lammps.limits import check_run_count
    from bkflow.sweeps.grid import phi_values, sweep_specs

    phis = phi_values(a.phi, a.points_per_decade)
    sizes = parse_sizes(a.sizes, parse_aspect(a.aspect))
    if a.jobs is not None and a.jobs < 1:
        raise SpecError(f"--jobs must be >= 1, got {a.jobs}")
    sets = run_assignments(a.set)
    axes = run_variations(a.vary)
    both = set(axes) & set(sets)
    if both:
        raise SpecError(f"--vary and --set both give {', '.join(sorted(both))}: choose one")
    routed = {k: sets.pop(k) for k in PROTOCOL_SETTINGS if k in sets}

    def fields(extra: dict) -> dict:
        """A grid point's fields: the protocol's rule fed by --set and this point's --vary
        values of the settings it takes (start, companion, t_end, ...), as the options."""
        own = {k: v for k, v in extra.items() if k in PROTOCOL_SETTINGS}
        return option_fields(a, {**routed, **own}, sets)

    check_run_count(math.prod([len(phis), len(sizes), a.seeds, *map(len, axes.values())]),
                    a.force)
    return phis, sizes, axes, sweep_specs(phis, sizes, a.seeds, axes=axes, fields=fields)


def _sweep(a) -> int:
    from bkflow.lammps.limits import check_sweep
    from bkflow.sweeps.lengths import check_lengths
    from bkflow.sweeps.local import available_cores, sweep
    from bkflow.sweeps.project import check_sweep_dir

    phis, sizes, axes, specs = _sweep_specs(a)
    settings = analysis_assignments(a.analysis) if a.analysis else None
    jobs = a.jobs or available_cores()
    check_sweep_dir(a.out)
    check_lengths(a.out, specs)
    total = check_sweep(specs, a.out, jobs, available_cores(), a.force)
    if a.init:  # what the jobs cost in all, on one core (a cluster divides it by its cores)
        print(report.cost_line(total, 1, any(s.adaptive for s in specs)), flush=True)
        return _init_jobs(a, specs, settings)
    cost = report.cost_line(total, jobs, any(s.adaptive for s in specs))
    for line in report.sweep_plan_lines(phis, len(sizes), axes, a.seeds, len(specs), a.out,
                                        jobs, cost):
        print(line, flush=True)
    rep = sweep(specs, a.out, jobs=jobs, progress=False if a.quiet else None,
                settings=settings, force=a.force)
    _print_sweep(a.out, rep, specs, list(axes))
    return _sweep_exit(rep)


def _init_jobs(a, specs, settings) -> int:
    """``bkflow sweep --init``: the jobs created, none run."""
    from bkflow.sweeps.lengths import init_jobs

    done = init_jobs(specs, a.out, settings, force=a.force)
    print("\n".join(report.jobs_created_lines(a.out, len(specs), done)))
    return 0


def _print_sweep(out, rep, specs, axes: list) -> None:
    """What the sweep ran, its table (this sweep's rows: the directory may hold other sweeps
    too) and the files it wrote."""
    from bkflow.store.tables import rows_of

    print(report.sweep_done_line(rep))
    res = rep.results
    if len(res):
        res = rows_of(res, specs)
        print("\n".join(report.results_lines(res, axes)))
    if len(res):
        print(report.states_line(res, max(s.t_end for s in specs)))
    print(report.tables_line(out))
    for line in report.retired_lines(out, rep.retired_figures):
        print(line)


#: the exit code of a sweep that did not finish every run, by ``report.sweep_outcome``'s kind
SWEEP_EXITS = {"busy": EXIT_BUSY, "refused": EXIT_BAD_INPUT, "failed": EXIT_RUN_FAILED}


def _sweep_exit(rep) -> int:
    """The sweep's exit code, its failed runs said on stderr."""
    for line in report.run_failed_lines(rep):
        guards.say(line)
    outcome = report.sweep_outcome(rep)
    if outcome is None:
        return 0
    kind, line = outcome
    guards.say(line)
    return SWEEP_EXITS[kind]


def _collect(a) -> int:
    from bkflow.sweeps.local import collect
    from bkflow.sweeps.project import open_project

    try:
        project = open_project(a.dir, create=False)
    except FileNotFoundError as exc:
        guards.say(f"bkflow: error: {exc}")
        return EXIT_BAD_INPUT
    settings = analysis_assignments(a.analysis) if a.analysis else None
    c = collect(project, settings)
    print(report.collect_line(a.dir, c))
    if len(c.results):
        from bkflow.store.tables import varied_parameters

        print("\n".join(report.results_lines(c.results, varied_parameters(c.results))))
        print(report.states_line(c.results))
    print(report.collected_tables_line(a.dir, c))
    for line in report.retired_lines(a.dir, c.retired_figures):
        print(line)
    for line in report.collect_problem_lines(a.dir, c):
        guards.say(line)
    return 0


# ------------------------------------------------------------------------- figures
def _plot(a) -> int:
    from bkflow.figures.style import PlotError
    from bkflow.figures.writer import plot

    formats = tuple(f.strip() for f in a.format.split(","))
    where = parse_where(a.where)
    from pathlib import Path

    from bkflow.store.tables import RUNS_FILE

    if not (Path(a.dir) / RUNS_FILE).exists() and rd.RunDir(a.dir).is_complete():
        # a run directory: its own figure (stress and R per block, the drops' distribution)
        from bkflow.api import plot_run

        if where:
            guards.say("bkflow: error: --where selects runs of a sweep; a run directory "
                       "has one run")
            return EXIT_BAD_INPUT
        try:
            paths = plot_run(a.dir, a.out, formats)
        except PlotError as exc:
            guards.say(f"bkflow: error: {exc}")
            return EXIT_BAD_INPUT
        for line in report.plot_lines(paths, {}):
            print(line)
        return 0
    try:
        paths, skipped = plot(a.dir, a.out, formats, where)
    except PlotError as exc:
        guards.say(f"bkflow: error: {exc}")
        return EXIT_BAD_INPUT
    for line in report.plot_lines(paths, skipped):
        print(line)
    return 0


def _movie_files(a):
    """The GIF and the maps ``bkflow movie`` writes: in an existing directory, never over a
    file of the user's."""
    from pathlib import Path

    from bkflow.store.files import foreign_file

    out = Path(a.out) if a.out else rd.RunDir(a.dir).movie_file(a.slip)
    if out.suffix.lower() != ".gif":
        raise SpecError(f"--out {out}: bkflow writes GIF movies (name it .gif)")
    maps = out.parent / layout.FRONT_MAPS_PATTERN.format(a.slip)
    if not out.parent.is_dir():
        raise SpecError(f"--out {out}: the directory {out.parent} does not exist")
    for p in (out, maps):  # a user's file of the same name is never replaced
        why = foreign_file(p)
        if why is not None:
            raise SpecError(why)
    return out, maps


def _movie(a) -> int:
    from bkflow.api import Run
    from bkflow.figures.style import STYLE, PlotError
    from bkflow.store.files import MARK, atomic_file

    if not 0.1 <= a.fps <= 50:
        raise SpecError(f"--fps must lie in [0.1, 50] (a GIF shows a frame for at least "
                        f"20 ms), got {a.fps:g}")
    if a.slip < 0:
        raise SpecError(f"--slip must be >= 0 (the recorded slips count from 0), got {a.slip}")
    try:
        run = Run(a.dir)
        fronts = run.fronts
    except (errors.AnalysisError, errors.DamagedRunError) as exc:
        guards.say(f"bkflow: error: {exc}")
        return EXIT_BAD_INPUT
    out, maps = _movie_files(a)
    try:
        fig = run.front_figure(a.slip)
        path = run.movie(a.slip, out, a.fps)
    except PlotError as exc:
        guards.say(f"bkflow: error: {exc}")
        return EXIT_BAD_INPUT
    with atomic_file(maps, binary=True) as fh:
        fig.savefig(fh, format=maps.suffix[1:], dpi=STYLE["savefig.dpi"], bbox_inches="tight",
                    metadata={"Creator": MARK})
    print(report.movie_line(path, fronts[a.slip], run.spec.dt, maps))
    return 0


# ------------------------------------------------------------------------- the command line
def main(argv=None) -> int:
    """The command line; returns the exit code (``EXIT_CODES``). SIGTERM and SIGHUP
    (a closed terminal) are taken as Ctrl-C: the command stops within a second, keeps what is
    finished, and the same command resumes; one started with it ignored (``nohup``) keeps
    ignoring it."""
    from bkflow.lammps import plugin

    with plugin.interrupts(guards.interrupt_signals()):
        return guards.guarded(lambda: _main(argv))


def _main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    refused = guards.mpi_refused()
    if refused is not None:
        return refused
    a = build_parser().parse_args(argv)
    paths = [p for p in (getattr(a, "out", None), getattr(a, "dir", None)) if p]
    refused = guards.paths_refused(paths)
    if refused is None:
        refused = guards.environment_refused()
    if refused is not None:
        return refused
    handlers = guards.failure_handlers()
    commands = {"run": lambda a: _run(a, argv), "analyze": _analyze, "sweep": _sweep,
                "plot": _plot, "collect": _collect, "movie": _movie, "deck": _deck}
    try:
        return commands[a.cmd](a)
    except (Exception, KeyboardInterrupt) as exc:
        return guards.failed(exc, a, handlers)


if __name__ == "__main__":
    raise SystemExit(main())
