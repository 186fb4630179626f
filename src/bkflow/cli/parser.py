"""The ``bkflow`` command line's parser: every command, option and help text
(``build_parser``), the synopses of the documentation (``synopsis``), and what the options of
a run mean as a RunSpec (``run_spec``: the protocol's rule fed by the options and ``--set``).
"""

from __future__ import annotations

import argparse

from bkflow import __version__
from bkflow.cli.assignments import OWN_OPTIONS, parse_size, run_assignments
from bkflow.cli.guards import EXIT_BAD_INPUT
from bkflow.model.checks import SpecError
from bkflow.model.params import (
    ADAPTIVE_CHUNK_T,
    ADAPTIVE_T_MIN,
    CONTACT_RULE_HELP,
    CONTACT_RULES,
    PAPER_SIZES,
    PATHS,
    PROTOCOLS,
    STARTS,
    STEADY_AGREEMENT,
    STEADY_COMPANION,
    STEADY_DRIFT_BOUND,
    STEADY_START,
    RunSpec,
    size_from_n,
)
from bkflow.model.protocols import protocol_fields
from bkflow.model.scenes import SCENES
from bkflow.model.settings import AnalysisSettings
from bkflow.model.timestep import ACCURACY, DT_FACTOR_MAX
from bkflow.store import layout
from bkflow.sweeps.grid import ASPECT, POINTS_PER_DECADE, SEEDS

#: what ``bkflow --help`` says bkflow is
DESCRIPTION = ("bkflow: Burridge-Knopoff friction (Giacco et al. 2014) on LAMMPS, from one run "
               "to a sweep.")


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
                   help="run until mu_bar's error (covering the layer's switching; with a "
                        "companion, of the pair's mean, the two agreeing within it) is below "
                        f"this (checked every {ADAPTIVE_CHUNK_T:g} time units from t = "
                        f"{ADAPTIVE_T_MIN:g}, ever more sparsely later), at most --t-end "
                        "(default: the steady protocol's preset target; none for the "
                        "paper's)")


def _contact_rule_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--contact-rule", choices=CONTACT_RULES, default=RunSpec.contact_rule,
                   help="contact rule at |k_e dr| > mu_s sigma_n A: " + ", ".join(
                       f"{rule} ({what})" for rule, what in CONTACT_RULE_HELP.items()))


def _analysis_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--analysis", action="append", default=[], metavar="NAME=VALUE",
                   help="an analysis setting (repeatable), with its default: " + ", ".join(
                       f"{k}={_setting_default(v)}"
                       for k, v in AnalysisSettings().to_dict().items()))


def _setting_default(v) -> str:
    """An analysis setting's default as --help shows it: None is the run's own value."""
    if v is None:
        return "the run's"
    return ",".join(map(str, v)) if isinstance(v, list) else str(v)


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


def _set_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="any other model or run parameter (repeatable), e.g. --set gamma=0.1 "
                        "--set V_d=0.05; it overrides the options above. Parameters: "
                        + ", ".join(f"{f}={getattr(RunSpec, f, None)}" for f in
                                    RunSpec.__dataclass_fields__
                                    if f not in OWN_OPTIONS))


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


def _path_arg(p) -> None:
    p.add_argument("--path", choices=PATHS, default="auto",
                   help="integration path: auto (default: the fused path whenever the lattice "
                        "is bkflow's, on any number of ranks; else the general path), general "
                        "(fix nve + fix bk/substrate + fix enforce2d, as before the fused path: "
                        "slower, same physics), fused (refuses what it cannot run)")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="bkflow", description=DESCRIPTION)
    p.add_argument("--version", action="version", version=f"bkflow {__version__}")
    sub = p.add_subparsers(dest="cmd", required=True, parser_class=_Parser)
    _run_commands(sub)
    _sweep_command(sub)
    _sweep_dir_commands(sub)
    _run_dir_commands(sub)
    return p


def _run_commands(sub) -> None:
    """bkflow run and bkflow deck."""
    r = sub.add_parser("run", help=f"run the model: writes {layout.DECK}, {layout.DATA}, "
                                   f"{layout.EXTREMA}, {layout.BLOCKS}, {layout.META} (and what "
                                   "the scene asks for)")
    _spec_args(r)
    r.add_argument("--overwrite", action="store_true", help="redo a finished run in --out")
    r.add_argument("--force", action="store_true",
                   help="run even above the cost limits (work, memory, disk; bkflow.lammps.limits)")
    r.add_argument("--quiet", action="store_true", help="no progress line")
    r.add_argument("--no-analyze", action="store_true",
                   help=f"skip the analysis ({layout.SUMMARY}); run bkflow analyze DIR later")
    _path_arg(r)
    d = sub.add_parser("deck", help=f"write {layout.DECK}, {layout.DATA}, {layout.PARAMS} "
                                    f"without running (lmp -in {layout.DECK})")
    _spec_args(d)
    _path_arg(d)


def _sweep_command(sub) -> None:
    """bkflow sweep."""
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
                    help=f"Lx/Ly every size must have: a number or a ratio such as 7/3 "
                         f"(default {ASPECT}, the paper's), or 'any'")
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


def _sweep_dir_commands(sub) -> None:
    """bkflow collect and bkflow plot, of a sweep directory."""
    co = sub.add_parser("collect", help="re-analyse what is stale, (re)write the tables from the "
                                        "finished runs of a sweep directory")
    co.add_argument("dir", help="sweep directory")
    _analysis_arg(co)
    pl = sub.add_parser("plot", help="the paper's figures from a sweep directory (PNG + PDF), "
                                     "or a run's own figure from a run directory")
    pl.add_argument("dir", help="sweep directory (bkflow sweep --out DIR), or run directory "
                                "(bkflow run --out DIR: its stress and R per block and its "
                                "drops' distribution, DIR/run.png)")
    pl.add_argument("--out", default=None, help="figure directory (default DIR/figures; for a "
                                                "run directory DIR itself)")
    pl.add_argument("--format", default="png,pdf", help="comma-separated formats (default png,pdf)")
    pl.add_argument("--where", action="append", default=[], metavar="COLUMN=VALUE",
                    help="plot only the runs with this parameter value (repeatable), e.g. "
                         "t_end=16000 or start=random, when the directory holds several sweeps")


def _run_dir_commands(sub) -> None:
    """bkflow analyze and bkflow movie, of a run directory."""
    an = sub.add_parser("analyze", help=f"analyse a finished run: writes DIR/{layout.SUMMARY}, "
                                        f"{layout.EVENTS_PARQUET} (+ {layout.PSI}, "
                                        f"{layout.CLUSTERS})")
    an.add_argument("dir", help=f"run directory (written by bkflow run or lmp -in {layout.DECK})")
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


# ------------------------------------------------------------------------- a run's RunSpec
#: RunSpec fields that the protocol's rule sets from options of their own (--start,
#: --companion, --t-end, ...): given with --set, they take the option's place in that rule,
#: so that every check of the option applies to them too
PROTOCOL_SETTINGS = ("start", "companion", "t_end", "dt_factor", "until_steady",
                     "target_error", "accuracy")


def option_fields(a, routed: dict, sets: dict, fixed: bool = False) -> dict:
    """The RunSpec fields of ``bkflow run``'s and ``bkflow sweep``'s options (all but phi,
    the size and the seed): the contact rule, the scene, the protocol's fields
    (``accuracy_fields``: ``routed``, the --set values of its settings, over the options;
    ``fixed``: a deck's fixed length) and the other --set values (``sets``)."""
    return {"contact_rule": a.contact_rule, "scene": a.scene,
            **accuracy_fields(a, routed, fixed), **sets}


def accuracy_fields(a, settings: dict | None = None, fixed: bool = False) -> dict:
    """The run's start, length rule, dt_factor and target_error: the protocol's, from the
    preset and the explicit options (bkflow.model.protocols.protocol_fields; ``fixed``: of a
    run of a fixed length, a deck); ``settings`` (of --set) override the options they name."""
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
    return protocol_fields(a.protocol, accuracy, **given, fixed=fixed)


def run_spec(a, deck: bool = False) -> RunSpec:
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
    sets = run_assignments(a.set)
    routed = {k: sets.pop(k) for k in PROTOCOL_SETTINGS if k in sets}
    return RunSpec(phi=a.phi, Lx=Lx, Ly=Ly, seed=a.seed,
                   **option_fields(a, routed, sets, fixed=deck))
