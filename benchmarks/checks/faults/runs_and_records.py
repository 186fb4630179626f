"""The cases of runs and records that are not what they seem: another run's restart file or
record ([F2], [F3], [F11]), a value written in place ([F5]), a continuation cut short ([F9]);
and of requests at the edges: every contact rule on both paths ([F1]), a lattice too small for
clusters ([F4]), estimates and extreme values ([F6]-[F8], [F13], [F14]), the cluster command
([F10], [F16], [F17]), advice followed ([F15]) and options repeated ([F18]). The tests of each
class are in tests/cli/test_faults_round4.py; these are the same attacks from outside.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from benchmarks.checks.faults.fuzz import Fuzz, bk

#: a run of the friction scene, quiet (its length given where it runs)
QUIET = ["--scene", "friction", "--quiet"]


def runs_and_records(fuzz: Fuzz) -> None:
    """Every case of this module, in order."""
    contact_rules(fuzz)
    d = two_seeds(fuzz)
    other_runs_files(fuzz, d)
    small_and_in_place(fuzz)
    estimates_and_extremes(fuzz, d)
    interrupted_continuation(fuzz, d)
    cluster_command(fuzz)
    impossible_values(fuzz, d)
    advised_and_repeated(fuzz)


def contact_rules(fuzz: Fuzz) -> None:
    """[F1] --contact-rule coulomb runs, on both paths."""
    for path in ("general", "fused"):
        fuzz.check(f"[F1] run --contact-rule coulomb --path {path}",
                   bk("run", "--phi", "10", "--contact-rule", "coulomb", "--path", path,
                      "--t-end", "300", *QUIET, "--out", fuzz.scratch() / "c"), {0})


def two_seeds(fuzz: Fuzz) -> Path:
    """A directory of two finished runs of the same lattice, seeds 1 and 2 (s1, s2)."""
    d = fuzz.scratch()
    for seed in (1, 2):
        bk("run", "--phi", "10", "--seed", seed, "--t-end", "300", *QUIET,
           "--out", d / f"s{seed}")
    return d


def other_runs_files(fuzz: Fuzz, d: Path) -> None:
    """[F2] [F3] another run's restart file or record, of the same size."""
    for what, src, dst in (("seed 1's restart in seed 2's run", "s1", "s2"),
                           ("the run's restart in its companion", "s2", "s2/companion")):
        case = fuzz.scratch() / "d"
        shutil.copytree(d, case)
        (restart,) = (case / src).glob("restart.*.bk")
        shutil.copy(restart, case / dst / restart.name)
        fuzz.check(f"[F2] run --t-end 600 with {what}",
                   bk("run", "--phi", "10", "--seed", "2", "--t-end", "600", *QUIET,
                      "--out", case / "s2"), {2}, not_finished=[])
    for name in ("blocks.npy", "psi.npy"):
        case = fuzz.scratch() / "d"
        shutil.copytree(d, case)
        if (case / "s1" / name).exists():
            shutil.copy(case / "s1" / name, case / "s2" / name)
            fuzz.check(f"[F3] analyze with seed 1's {name} in seed 2's run",
                       bk("analyze", case / "s2"), {1, 2})


def small_and_in_place(fuzz: Fuzz) -> None:
    """[F4] a small lattice whose slips form no cluster; [F5] a NaN written in place into a
    sweep's run: the sweep redoes it."""
    fuzz.check("[F4] run --size 3x3 --t-end 30000 --scene figures, then analyze",
               bk("run", "--phi", "10", "--size", "3x3", "--t-end", "30000", "--scene",
                  "figures", "--quiet", "--out", fuzz.scratch() / "r"), {0})
    s = fuzz.scratch() / "s"
    args = ["sweep", "--phi", "10", "--seeds", "1", "--t-end", "300", *QUIET, "--jobs", "1",
            "--out", s]
    bk(*args)
    (blocks,) = s.glob("workspace/*/blocks.npy")
    r = np.load(blocks, mmap_mode="r+")
    r["sigma"][2] = np.nan
    r.flush()
    del r
    fuzz.check("[F5] the same sweep after a NaN written into a run in place", bk(*args), {0})


def estimates_and_extremes(fuzz: Fuzz, d: Path) -> None:
    """[F6] the disk estimate of the fronts, refused up front on a small disk; [F7] the contact
    area; [F8] phase_every beyond a tenth of a block, [F13] extreme finite inputs, [F14]
    n_blocks."""
    fuzz.check("[F6] a fronts run whose records do not fit (1 MB free, simulated)",
               subprocess.run([sys.executable, "-c",
                               "from bkflow.lammps import limits\n"
                               "from bkflow.model.params import RunSpec\n"
                               "limits._free_disk = lambda p: 1e6\n"
                               "from bkflow.cli.commands import main\n"
                               "raise SystemExit(main(['run', '--phi', '10', '--t-end', '4000', "
                               f"'--scene', 'fronts', '--out', {str(fuzz.scratch() / 'f')!r}]))"],
                              capture_output=True, text=True), {2})
    out = fuzz.scratch() / "a"
    p = bk("run", "--phi", "10", "--set", "area=2", "--t-end", "1000", *QUIET, "--out", out)
    mu = json.loads((out / "summary.json").read_text())["mu_bar"] if p.returncode == 0 else None
    fuzz.check("[F7] run --set area=2 (mu_bar below mu_s)", p, {0})
    if mu is not None and not mu < 0.2:
        fuzz.results[-1].verdict = f"mu_bar = {mu} above mu_s"
    for name, extra, code in (
            ("[F8] run --set phase_every=500", ["--set", "phase_every=500"], {2}),
            ("[F13] run --phi 1e308", ["--phi", "1e308"], {2}),
            ("[F13] run --set mass=1e-320", ["--set", "mass=1e-320"], {2}),
            ("[F13] run --dt-factor 1e-320", ["--dt-factor", "1e-320"], {2}),
            ("[F13] run --phi 1e20", ["--phi", "1e20"], {2}),
            ("[F13] run --set mu_s=1e-200 --set sigma_n=1e-200",
             ["--set", "mu_s=1e-200", "--set", "sigma_n=1e-200"], {2})):
        phi = [] if "--phi" in extra else ["--phi", "10"]
        fuzz.check(name, bk("run", *phi, *extra, "--t-end", "100", *QUIET, "--out",
                            fuzz.scratch() / "r"), code)
    fuzz.check("[F14] analyze --analysis n_blocks=1000000",
               bk("analyze", d / "s1", "--analysis", "n_blocks=1000000"), {2})


def interrupted_continuation(fuzz: Fuzz, d: Path) -> None:
    """[F9] the advice after an interrupted continuation, and the advice followed."""
    case = fuzz.scratch() / "d"
    shutil.copytree(d, case)
    (case / "s1" / ".bkflow-continuing").write_text(
        str(json.loads((case / "s1" / "meta.json").read_text())["restart"]))
    with open(case / "s1" / "blocks.npy", "ab") as f:
        f.write(b"\0" * 64)     # what a continuation appended before it was killed
    p = subprocess.run([sys.executable, "-c", "import sys, bkflow, bkflow.store.errors\n"
                        "try:\n"
                        f"    bkflow.load_run({str(case / 's1')!r}).summary\n"
                        "except bkflow.store.errors.DamagedRunError as e:\n"
                        "    sys.exit(f'load_run: {e}')"],
                       capture_output=True, text=True)
    fuzz.check("[F9] load_run().summary after an interrupted continuation", p, {1})
    if "--overwrite" in p.stderr:
        fuzz.results[-1].verdict = "advises --overwrite"
    fuzz.check("[F9] ... and the advice followed: bkflow analyze", bk("analyze", case / "s1"),
               {0})


def cluster_command(fuzz: Fuzz) -> None:
    """[F10] [F16] [F17] the cluster command: without a scheduler, a near-miss operation, and
    the job scripts' python under an odd path."""
    g = fuzz.scratch() / "g"
    bk("sweep", "--phi", "1", "--seeds", "1", "--t-end", "100", "--init", "--out", g)
    env = {**os.environ, "SIGNAC_FLOW_ENVIRONMENT": "StandardEnvironment"}
    for name, args, code in (("[F16] cluster submit --pretend without a scheduler",
                              ["submit", "--pretend"], {1}),
                             ("[F17] cluster run -o simulat", ["run", "-o", "simulat"], {2})):
        fuzz.check(name, subprocess.run([sys.executable, "-m", "bkflow.slurm", *args], cwd=g,
                                        env=env, capture_output=True, text=True), code)
    odd = f"{fuzz.scratch()}/my env/$(touch pwned)/python"
    p = subprocess.run([sys.executable, "-c", f"import shlex, sys; sys.executable = {odd!r}\n"
                        "from bkflow.sweeps.slurm import project\n"
                        "words = shlex.split(project()._entrypoint['executable'])\n"
                        f"sys.exit(0 if words == [{odd!r}] else 'split: ' + repr(words))"],
                       cwd=g, env=env, capture_output=True, text=True)
    fuzz.check("[F10] the job scripts' python under a path with a space and $(...)", p, {0})


def impossible_values(fuzz: Fuzz, d: Path) -> None:
    """[F11] impossible values in records (a run recorded before digests, or standalone).
    [F12], a --jobs 1 sweep whose directory is removed, is a race: tests/cli/test_faults.py
    has it, and no fixed case here."""
    for field, value in (("psi", 5.0), ("R", 1e6)):
        case = fuzz.scratch() / "d"
        shutil.copytree(d, case)
        name = "psi.npy" if field == "psi" else "blocks.npy"
        if not (case / "s1" / name).exists():
            continue
        r = np.load(case / "s1" / name, mmap_mode="r+")
        r[field][1] = value
        r.flush()
        del r
        meta = json.loads((case / "s1" / "meta.json").read_text())
        meta.pop("file_sha256", None)
        (case / "s1" / "meta.json").write_text(json.dumps(meta))
        (case / "s1" / "summary.json").unlink(missing_ok=True)
        fuzz.check(f"[F11] analyze with {field} = {value:g} in {name}",
                   bk("analyze", case / "s1"), {1, 2})


def advised_and_repeated(fuzz: Fuzz) -> None:
    """[F15] the --aspect a refusal advises is accepted; [F18] --where repeated."""
    p = bk("sweep", "--phi", "1", "--sizes", "7x3", "--seeds", "1", "--t-end", "100",
           "--init", "--out", fuzz.scratch() / "a")
    advised = p.stderr.split("pass --aspect ", 1)[-1].split(" ")[0]
    fuzz.check(f"[F15] sweep --sizes 7x3 --aspect {advised} (the advised one)",
               bk("sweep", "--phi", "1", "--sizes", "7x3", "--aspect", advised, "--seeds", "1",
                  "--t-end", "100", "--init", "--out", fuzz.scratch() / "b"), {0})
    fuzz.check("[F18] plot --where phi=1 --where phi=10",
               bk("plot", fuzz.sweep, "--out", fuzz.scratch() / "f", "--where", "phi=1",
                  "--where", "phi=10"), {0})
