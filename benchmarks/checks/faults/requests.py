"""The cases of what a user asks for and is told: a sweep into the user's files ([3]), a deck
over theirs ([4]), figures and movies whole or not at all ([5]), parameters out of their domain
([6]), the environment named and not blamed on the run ([7]), one analysis per figure set
([8]), lmp -in inside a finished run ([9]), options and counts ([10]), other tracebacks ([12]),
and the documented commands of the cluster ([14]).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time

from benchmarks.checks.faults.fuzz import SHORT, Fuzz, bk, digest, whole_figure
from benchmarks.harness import BKFLOW, ROOT, tool


def users_tables(fuzz: Fuzz) -> None:
    """[3] a sweep into a directory of the user's files, or into a finished run, is refused
    and changes nothing."""
    def sweep_into(d, label):
        before = digest(d)
        p = bk("sweep", "--phi", "1", "--seeds", "1", "--t-end", "50", "--scene",
               "friction", "--out", d)
        fuzz.check(f"[3] sweep --out {label}", p, {2})
        if digest(d) != before:
            fuzz.results[-1].verdict = "changed the user's files"

    for label, files in (("a directory of the user's tables",
                          {"results.csv": "mine", "runs.csv": "mine",
                           "analysis.json": "{}"}),
                         ("a directory of the user's notes", {"notes.txt": "mine"}),
                         ("a foreign signac project",
                          {".signac/config": "schema_version = 2\n",
                           "signac_project_document.json": '{"mine": 1}'})):
        d = fuzz.scratch() / "u"
        for rel, text in files.items():
            (d / rel).parent.mkdir(parents=True, exist_ok=True)
            (d / rel).write_text(text)
        sweep_into(d, label)
    fuzz.check("[3] sweep --out a finished run", bk("sweep", "--phi", "1", "--out",
                                                    fuzz.base), {2})


def users_decks(fuzz: Fuzz) -> None:
    """[4] a deck over the user's own or edited deck is refused and changes nothing."""
    for label, edit in (("a hand-written in.bk", None), ("an edited in.bk", "in.bk"),
                        ("an edited data.bk", "data.bk"),
                        ("an edited params.json", "params.json")):
        d = fuzz.scratch() / "deck"
        if edit is None:
            d.mkdir()
            (d / "in.bk").write_text("units lj\n")
        else:
            bk("deck", "--phi", "10", "--out", d)
            (d / edit).write_text((d / edit).read_text().replace("1", "2", 1))
        before = digest(d)
        fuzz.check(f"[4] deck --out over {label}", bk("deck", "--phi", "3", "--out", d),
                   {2})
        if digest(d) != before:
            fuzz.results[-1].verdict = "replaced the user's deck"


def whole_figures(fuzz: Fuzz) -> None:
    """[5] a signal during plot leaves the old figure or the new one, never a cut one."""
    figs = fuzz.scratch() / "figs"
    bk("plot", fuzz.sweep, "--out", figs)
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGKILL):
        for delay in (0.8, 1.6):
            p = subprocess.Popen([BKFLOW, "plot", str(fuzz.sweep), "--out", str(figs)],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            time.sleep(delay)
            p.send_signal(sig)
            out, err = p.communicate(timeout=60)
            # SIGKILL leaves no chance to clean up: its temporary stays, hidden (.name)
            # and never taken for a figure; the figures themselves must be whole
            bad = [f.name for f in figs.iterdir() if f.suffix in (".png", ".pdf")
                   and not whole_figure(f)] + [f.name for f in figs.iterdir()
                                                if f.name.endswith(".tmp")
                                                and sig != signal.SIGKILL]
            fuzz.check(f"[5] {signal.Signals(sig).name} during plot after {delay} s",
                       subprocess.CompletedProcess(p.args, 0 if not bad else 1, out, err),
                       {0})
            if bad:
                fuzz.results[-1].verdict = f"left {', '.join(bad[:3])}"


def whole_movies(fuzz: Fuzz) -> None:
    """[5] a full disk during a movie leaves no cut movie and no temporary."""
    small = fuzz.scratch() / "small"
    if not fuzz.tmpfs(small, "size=64k"):
        fuzz.skip("[5] full disk during movie", "mount not allowed here")
        return
    try:
        for name in ("slip.gif", "other.gif"):
            p = bk("movie", fuzz.base, "--out", small / name)
            fuzz.check(f"[5] full disk during movie ({name})", p, {4})
            left = [n for n in os.listdir(small) if n.endswith((".gif", ".tmp"))]
            if left:
                fuzz.results[-1].verdict = f"left {', '.join(left)}"
    finally:
        subprocess.run(["umount", str(small)])


def misread(fuzz: Fuzz) -> None:
    """[6]-[9] parameters out of their domain, the environment, mixed analyses, lmp -in in a
    finished run."""
    for case, args in (("--set V_d=-0.02", ["--set", "V_d=-0.02"]),
                       ("--set V_d=0", ["--set", "V_d=0"]),
                       ("--set V_d=1 (0.014 l per step)", ["--set", "V_d=1"]),
                       ("--set gamma=-1", ["--set", "gamma=-1"]),
                       ("--set mass=0", ["--set", "mass=0"]),
                       ("--set bond_limit=0.5", ["--set", "bond_limit=0.5"]),
                       ("--set k_e=-10", ["--set", "k_e=-10"]),
                       ("--analysis alpha=2", ["--analysis", "alpha=2"]),
                       ("--analysis n_blocks=1", ["--analysis", "n_blocks=1"]),
                       ("--analysis span_fraction=0", ["--analysis", "span_fraction=0"])):
        out = fuzz.scratch() / "r"
        cmd = "sweep" if args[0] == "--analysis" else "run"
        fuzz.check(f"[6] {cmd} {case}", bk(cmd, "--phi", "10", *SHORT, *args, "--out", out),
                   {2}, [out])
    for case, env, code in (("OMP_NUM_THREADS=4,2 (valid OpenMP)",
                             {"OMP_NUM_THREADS": "4,2"}, 0),
                            ("OMP_NUM_THREADS=abc", {"OMP_NUM_THREADS": "abc"}, 2),
                            ("OMP_NUM_THREADS=1.5", {"OMP_NUM_THREADS": "1.5"}, 2),
                            ("NUMEXPR_NUM_THREADS=x", {"NUMEXPR_NUM_THREADS": "x"}, 2)):
        d = fuzz.scratch() / "run"
        shutil.copytree(fuzz.base, d)
        p = bk("analyze", d, env={**os.environ, **env})
        fuzz.check(f"[7] analyze with {case}", p, {code})
        if "damaged" in p.stderr:
            fuzz.results[-1].verdict = "called the run damaged"
    import resource

    for limit in (300, 450):
        def cap(mb=limit):
            resource.setrlimit(resource.RLIMIT_AS, (mb * 2**20, mb * 2**20))
        d = fuzz.scratch() / "run"
        shutil.copytree(fuzz.base, d)
        p = bk("analyze", d, preexec_fn=cap)
        fuzz.check(f"[7] analyze under a {limit} MB memory limit", p, {0, 5})
        if "damaged" in p.stderr:
            fuzz.results[-1].verdict = "called the run damaged"
    # analysis settings mixed in one figure set
    from bkflow.analysis.summary import analyze
    from bkflow.model.settings import AnalysisSettings

    for threshold in (0.05, 0.02):
        d = fuzz.scratch() / "s"
        shutil.copytree(fuzz.sweep, d)
        job = sorted((d / "workspace").iterdir())[0]
        analyze(job, AnalysisSettings(slip_threshold=threshold))
        fuzz.check(f"[8] plot after a collect --analysis slip_threshold={threshold} cut "
                   "short", bk("plot", d), {2})
    d = fuzz.scratch() / "s"
    shutil.copytree(fuzz.sweep, d)
    doc = d / "signac_project_document.json"
    data = json.loads(doc.read_text()) if doc.exists() else {}
    data["analysis_settings"] = {"s_x": 0.02}
    doc.write_text(json.dumps(data))
    fuzz.check("[8] plot when the sweep's settings are not its tables'", bk("plot", d), {2})
    # lmp -in inside a finished run
    lmp_bin = tool("lmp")
    for case, extra in (("a fixed run", []), ("an adaptive pair", ["--size", "12x3",
                                                                  "--target-error", "2e-3",
                                                                  "--protocol", "steady"])):
        d = fuzz.scratch() / "r"
        bk("run", "--phi", "10", "--t-end", "200", *extra, "--quiet", "--out", d)
        for where in (d, d / "companion"):
            if (where / "in.bk").exists():
                subprocess.run([lmp_bin, "-in", "in.bk", "-screen", "none"], cwd=where,
                               check=True)
        p = bk("analyze", d)
        fuzz.check(f"[9] analyze after lmp -in in.bk inside {case}", p, {0})
    d = fuzz.scratch() / "s"
    shutil.copytree(fuzz.sweep, d)
    job = sorted((d / "workspace").iterdir())[0]
    subprocess.run([lmp_bin, "-in", "in.bk", "-screen", "none"], cwd=job, check=True)
    p = bk("sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--scene",
           "friction", "--jobs", "2", "--out", d, "--quiet")
    fuzz.check("[9] the sweep after lmp -in in one of its runs", p, {0})
    if "0 run(s) done" not in p.stdout:
        fuzz.results[-1].verdict = "redid a run"


def options(fuzz: Fuzz) -> None:
    """[10] options and counts: a near-miss option is refused, a busy run is busy, old
    figures go."""
    for case, args in (("run --over (not --overwrite)",
                        ["run", "--phi", "10", "--t-end", "200", "--over", "--out",
                         fuzz.base]),
                       ("run --overw", ["run", "--phi", "10", "--overw", "--out", fuzz.base]),
                       ("sweep --seed 3", ["sweep", "--phi", "1", "--seed", "3", "--out",
                                           fuzz.scratch() / "s"]),
                       ("sweep --point 3", ["sweep", "--phi", "1:10", "--point", "3",
                                            "--out", fuzz.scratch() / "s"])):
        fuzz.check(f"[10] {case}", bk(*args), {2})
    # a run that another process writes is busy, not failed
    d = fuzz.scratch() / "s"
    args = ["sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--scene",
            "friction", "--jobs", "1", "--quiet", "--out", str(d)]
    bk(*args, "--init")
    job = sorted((d / "workspace").iterdir())[0]
    holder = subprocess.Popen([sys.executable, "-c", (
        "import fcntl, os, sys, time\n"
        f"fd = os.open({str(job / '.bkflow.lock')!r}, os.O_RDWR | os.O_CREAT)\n"
        "fcntl.flock(fd, fcntl.LOCK_EX)\nprint('held', flush=True)\ntime.sleep(60)")],
        stdout=subprocess.PIPE, text=True)
    holder.stdout.readline()
    p = bk(*args)
    holder.kill()
    fuzz.check("[10] a sweep beside a run another process holds", p, {3})
    if "failed" in p.stdout.replace("0 failed", "") or \
            "written by another process" not in p.stdout:
        fuzz.results[-1].verdict = "said failed, or did not say busy"
    p = bk(*args)
    fuzz.check("[10] ... the same command once it is free", p, {0})
    # figures of old tables after a second sweep
    d = fuzz.scratch() / "s"
    shutil.copytree(fuzz.sweep, d)
    bk("plot", d)
    p = bk("sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "150", "--scene",
           "friction", "--jobs", "2", "--out", d, "--quiet")
    left = sorted((d / "figures").glob("*.png")) if (d / "figures").exists() else []
    fuzz.check("[10] figures after a second sweep with another t_end", p, {0})
    if left:
        fuzz.results[-1].verdict = f"left {len(left)} figures of the old tables"


def tracebacks(fuzz: Fuzz) -> None:
    """[12] the tracebacks found elsewhere: odd values, names and environments."""
    d = fuzz.scratch() / "vg"
    bk("sweep", "--phi", "1", "--seeds", "1", "--t-end", "100", "--scene", "friction",
       "--protocol", "paper", "--vary", "gamma=1e-9,1e-10", "--out", d, "--quiet")
    fuzz.check("[12] plot --where gamma=1e-9 of gamma=1e-9,1e-10",
               bk("plot", d, "--where", "gamma=1e-9"), {0})
    fuzz.check("[12] plot of --vary gamma=1e-9,1e-10", bk("plot", d), {0})
    bad = os.fsdecode(os.fsencode(str(fuzz.scratch())) + b"/bad\xff")
    for cmd in (["sweep", "--phi", "1", "--out", bad], ["collect", bad], ["plot", bad]):
        p = subprocess.run([BKFLOW, *cmd], capture_output=True, text=True,
                           errors="replace")
        fuzz.check(f"[12] {cmd[0]} into a non-UTF-8 name", p, {2})
    for case, env, code in (("SIGNAC_FLOW_ENVIRONMENT=garbage",
                             {"SIGNAC_FLOW_ENVIRONMENT": "garbage"}, 0),
                            ("MPLBACKEND=garbage", {"MPLBACKEND": "garbage"}, 0),
                            ("TQDM_MININTERVAL=abc", {"TQDM_MININTERVAL": "abc"}, 2),
                            ("TQDM_NCOLS=x", {"TQDM_NCOLS": "x"}, 2)):
        out = fuzz.scratch() / "s"
        p = bk("sweep", "--phi", "1", "--seeds", "1", "--t-end", "50", "--scene",
               "friction", "--out", out, "--quiet", env={**os.environ, **env})
        fuzz.check(f"[12] sweep with {case}", p, {code})
    out = fuzz.scratch() / "r"
    p = subprocess.run(f"'{BKFLOW}' run --phi 10 {' '.join(SHORT)} --out '{out}' 2>&-",
                       shell=True, capture_output=True, text=True)
    fuzz.check("[12] run with stderr closed", p, {0})
    gone = fuzz.scratch() / "gone"
    for case, out, code in (("an absolute --out", fuzz.scratch() / "r", 0),
                            ("a relative --out", "r", 4)):
        gone.mkdir(exist_ok=True)
        p = subprocess.run(f"cd '{gone}' && rmdir '{gone}' && '{BKFLOW}' run --phi 10 "
                           f"{' '.join(SHORT)} --out '{out}'", shell=True,
                           capture_output=True, text=True)
        fuzz.check(f"[12] run in a deleted directory with {case}", p, {code})


def docs(fuzz: Fuzz) -> None:
    """[14] every documented `python -m bkflow.slurm run` runs."""
    import re

    texts = [(ROOT / f).read_text() for f in ("README.md", "docs/slurm.md",
                                               "src/bkflow/slurm.py")]
    cmds = sorted({m.strip() for t in texts
                   for m in re.findall(r"python -m bkflow\.slurm run([^`\n#]*)", t)})
    for args in cmds:
        d = fuzz.scratch() / "c"
        bk("sweep", "--phi", "1,3", "--seeds", "1", "--t-end", "50", "--scene", "friction",
           "--protocol", "paper", "--out", d, "--init")
        p = subprocess.run([sys.executable, "-m", "bkflow.slurm", "run", *args.split()],
                           cwd=d, capture_output=True, text=True, timeout=600)
        p = subprocess.CompletedProcess(p.args, p.returncode, p.stdout, "")  # flow's bars
        fuzz.check(f"[14] the documented `python -m bkflow.slurm run {args}`", p, {0})


def cluster(fuzz: Fuzz) -> None:
    """[14] the cluster command's refusals."""
    for args in (["status", "-j", "nosuchjob"], ["run", "-j", "deadbeef"],
                 ["exec", "simulate", "nosuchjob"], ["submit", "--bundle", "-1",
                                                     "--pretend"]):
        d = fuzz.scratch() / "s"
        shutil.copytree(fuzz.sweep, d)
        p = subprocess.run([sys.executable, "-m", "bkflow.slurm", *args], cwd=d,
                           capture_output=True, text=True, timeout=120,
                           env={**os.environ,
                                "SIGNAC_FLOW_ENVIRONMENT": "StandardEnvironment"})
        fuzz.check(f"[14] python -m bkflow.slurm {' '.join(args)}", p, {2})
