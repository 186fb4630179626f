"""Command line: ``bkflow run``, ``bkflow analyze`` and ``bkflow deck``.

Bad input gets one line on stderr naming the problem and exit code 2; a run that fails
(blow-up, LAMMPS error) exits 1. Nothing half-written is left looking complete: a run
directory counts as finished only once its meta.json says so.
"""

from __future__ import annotations

import argparse
import shlex
import sys

from . import __version__
from .params import SCENES, RunSpec, SpecError, parse_size, size_from_n

EXIT_BAD_INPUT = 2
EXIT_RUN_FAILED = 1


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse prints the usage too)
        self.exit(EXIT_BAD_INPUT, f"bkflow: error: {message}\n")


def _spec_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--phi", type=float, required=True, help="k_b / dk_d (> 0)")
    size = p.add_mutually_exclusive_group()
    size.add_argument("--size", help="lattice LXxLY, e.g. 20x5 (default 20x5)")
    size.add_argument("--n", type=int, help="the paper's sizes: 100, 400 or 900 (Ly = Lx/4)")
    p.add_argument("--t-end", type=float, default=RunSpec.t_end, help="run length (time units)")
    p.add_argument("--seed", type=int, default=RunSpec.seed, help="seed of the k_d^i draw")
    p.add_argument("--dt-factor", type=float, default=RunSpec.dt_factor,
                   help="C in dt = C / sqrt(4 k_b + k_e + k_d + dk_d)")
    p.add_argument("--friction", choices=("reset", "coulomb"), default=RunSpec.friction,
                   help="contact rule at |k_e dr| > mu_s sigma_n A (default reset, the paper's)")
    p.add_argument("--scene", choices=SCENES, default=RunSpec.scene,
                   help="what to record: friction (sigma_x only), order (+ snapshots for "
                        "Psi(t)), clusters (+ positions at each slip), full (default)")
    p.add_argument("--out", required=True, help="output directory")


def _spec(a) -> RunSpec:
    if a.n is not None:
        Lx, Ly = size_from_n(a.n)
    elif a.size is not None:
        Lx, Ly = parse_size(a.size)
    else:
        Lx, Ly = RunSpec.Lx, RunSpec.Ly
    return RunSpec(phi=a.phi, Lx=Lx, Ly=Ly, seed=a.seed, t_end=a.t_end, dt_factor=a.dt_factor,
                   friction=a.friction, scene=a.scene)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="bkflow", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"bkflow {__version__}")
    sub = p.add_subparsers(dest="cmd", required=True, parser_class=_Parser)
    r = sub.add_parser("run", help="run the model: writes in.bk, data.bk, stress.csv, meta.json")
    _spec_args(r)
    r.add_argument("--overwrite", action="store_true", help="redo a finished run in --out")
    r.add_argument("--quiet", action="store_true", help="no progress line")
    r.add_argument("--no-analyze", action="store_true",
                   help="skip the analysis (summary.json); run bkflow analyze DIR later")
    d = sub.add_parser("deck", help="write in.bk and data.bk without running (lmp -in in.bk)")
    _spec_args(d)
    an = sub.add_parser("analyze", help="analyse a finished run: writes DIR/summary.json "
                                        "(+ psi.csv, clusters.csv)")
    an.add_argument("dir", help="run directory (written by bkflow run or lmp -in in.bk)")
    return p


def _print_summary(s: dict) -> None:
    def g(key, fmt):
        v = s.get(key)
        return "n/a" if v is None else format(v, fmt)

    print(f"  mu_bar = {g('mu_bar', '.4f')} +- {g('mu_bar_err', '.4f')} over {s['n_slips']} "
          f"slips (threshold {s['slip_threshold_stress']:g}); <sigma_x>/sigma_n = "
          f"{g('mean_stress_ratio', '.4f')}")
    by = ", ".join(f"{k}: {'n/a' if v is None else format(v, '.4f')}"
                   for k, v in s["mu_bar_by_threshold"].items())
    print(f"  mu_bar by threshold (fraction of mu_s sigma_n): {by}")
    if s.get("psi_inf") is not None:
        print(f"  Psi(inf) = {s['psi_inf']:.4f}")
    if s.get("n_clusters") is not None:
        print(f"  clusters: {s['n_clusters']} in {s['n_cluster_events']} slips, "
              f"<l_x/Lx> = {g('lx_mean_over_Lx', '.3f')}, <l_y/Ly> = "
              f"{g('ly_mean_over_Ly', '.3f')}, <l_x>/<l_y> = {g('lx_over_ly', '.3f')}, "
              f"regime {s.get('regime') or 'n/a'}")
    print(f"  stress drops: exponent {g('drop_exponent', '.2f')} +- "
          f"{g('drop_exponent_err', '.2f')} above {g('drop_x_min', '.3g')} "
          f"({s['drop_n_tail']} drops)")


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    a = build_parser().parse_args(argv)
    from .engine import RunError, RunExistsError
    from .plugin import PluginError

    try:
        if a.cmd == "analyze":
            from .analysis import analyze

            try:
                summary = analyze(a.dir)
            except (ValueError, OSError) as exc:  # missing, partial or corrupt run files
                print(f"bkflow: error: cannot analyse {a.dir}: {exc}", file=sys.stderr)
                return EXIT_BAD_INPUT
            print(f"{a.dir}/summary.json written")
            _print_summary(summary)
            return 0
        spec = _spec(a)
        if a.cmd == "deck":
            from .deck import write_deck

            paths = write_deck(spec, a.out)
            print(f"wrote {paths['deck']} and {paths['data']} ({spec.n_steps} steps)")
            return 0
        from .engine import run

        res = run(spec, a.out, overwrite=a.overwrite, progress=None if not a.quiet else False,
                  command="bkflow " + shlex.join(argv))
        m = res.meta
        print(f"{a.out}: {spec.n_steps} steps in {m['wall_time_s']:.1f} s "
              f"({m['atom_steps_per_s']:.3g} atom-steps/s), {m['contact_breaks']} contact breaks")
        if not a.no_analyze:
            from .analysis import analyze

            _print_summary(analyze(a.out))
        return 0
    except (SpecError, RunExistsError, PluginError, FileNotFoundError) as exc:
        print(f"bkflow: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except RunError as exc:
        print(f"bkflow: run failed: {exc}", file=sys.stderr)
        return EXIT_RUN_FAILED


if __name__ == "__main__":
    raise SystemExit(main())
