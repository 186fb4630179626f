"""The cases of what bkflow may touch and what it says: nothing outside the directory it is
given ([T1]), job scripts as Slurm reads them ([T2]), records that exclude each other or
repair themselves ([T3]-[T6]), a foreign companion ([T7]), the API's errors ([T8]), ``--set``
through the options' checks ([T9]), advice about what changed ([T10]), printed commands safe to
paste ([T11]), a planted mark ([T12]); and the cases of a fresh attack ([F]).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from benchmarks.checks.faults.fuzz import SHORT, Fuzz, Result, bk, digest
from benchmarks.harness import BKFLOW


def users_file(fuzz: Fuzz) -> tuple[Path, str]:
    """A file outside every directory a case gives bkflow, and its digest."""
    v = fuzz.scratch() / "victim.txt"
    v.write_text("the user's file\n")
    return v, hashlib.sha256(v.read_bytes()).hexdigest()


def untouched(fuzz: Fuzz, victim: Path, sha: str) -> None:
    if not victim.exists() or hashlib.sha256(victim.read_bytes()).hexdigest() != sha:
        fuzz.results[-1].verdict = "touched a file outside the directory"


def outside_untouched(fuzz: Fuzz) -> None:
    """[T1] nothing outside the directory is deleted, replaced or written through."""
    for how in ("absolute path", "../ path", "symlink in figures/"):
        d = fuzz.sweep_copy()
        victim, sha = users_file(fuzz)
        fig = d / "figures"
        fig.mkdir(exist_ok=True)
        if how == "symlink in figures/":
            (fig / "link.png").symlink_to(victim)
            names = ["link.png"]
        else:
            names = [str(victim) if how == "absolute path"
                     else os.path.relpath(victim, fig)]
        (fig / "figures.json").write_text(json.dumps({"tables_sha256": "0",
                                                      "files": names}))
        fuzz.check(f"[T1] collect with figures.json naming the user's file ({how})",
                   bk("collect", d), {0, 2})
        untouched(fuzz, victim, sha)
    for planted in ("figures -> outside", "workspace -> outside", "a job -> outside"):
        d = fuzz.sweep_copy()
        outside = fuzz.scratch() / "outside"
        outside.mkdir()
        victim = outside / "keep.txt"
        victim.write_text("mine\n")
        sha = hashlib.sha256(victim.read_bytes()).hexdigest()
        if planted.startswith("figures"):
            shutil.rmtree(d / "figures", ignore_errors=True)
            (d / "figures").symlink_to(outside)
            cmd = ["plot", d]
        elif planted.startswith("workspace"):
            shutil.copytree(d / "workspace", outside / "ws")
            shutil.rmtree(d / "workspace")
            (d / "workspace").symlink_to(outside / "ws")
            cmd = ["collect", d]
        else:
            job = sorted((d / "workspace").iterdir())[0]
            shutil.move(str(job), str(outside / job.name))
            job.symlink_to(outside / job.name)
            cmd = ["collect", d]
        before = digest(outside)
        fuzz.check(f"[T1] {cmd[0]} of a sweep whose {planted}", bk(*cmd), {0, 2})
        if digest(outside) != before:
            fuzz.results[-1].verdict = "changed a file outside the directory"
        untouched(fuzz, victim, sha)
    d = fuzz.scratch() / "run"
    shutil.copytree(fuzz.base, d)
    victim, sha = users_file(fuzz)
    (d / "extrema.npy").unlink()   # a record every scene's run writes again
    (d / "extrema.npy").symlink_to(victim)
    fuzz.check("[T1] run --overwrite of a run whose extrema.npy links out",
               bk("run", "--phi", "10", "--t-end", "200", "--overwrite", "--quiet",
                  "--out", d), {0, 2})
    untouched(fuzz, victim, sha)


def job_scripts(fuzz: Fuzz) -> None:
    """[T2] the job script as Slurm reads it: one option per #SBATCH line."""
    d = fuzz.scratch() / "g"
    bk("sweep", "--phi", "1,3", "--seeds", "1", "--t-end", "50", "--scene", "friction",
       "--out", d, "--init")
    fake = fuzz.scratch()   # a scheduler with an empty queue: what submit asks first
    (fake / "squeue").write_text("#!/bin/sh\nexit 0\n")
    (fake / "squeue").chmod(0o755)
    env = {**os.environ, "SIGNAC_FLOW_ENVIRONMENT": "DefaultSlurmEnvironment",
           "PATH": f"{fake}{os.pathsep}{os.environ['PATH']}"}
    for extra in ([], ["--bundle", "2", "--parallel"]):
        p = subprocess.run([sys.executable, "-m", "bkflow.slurm", "submit", "--pretend",
                            *extra], cwd=d, capture_output=True, text=True, timeout=120,
                           env=env)
        # sbatch reads a directive up to a second "#": an option after it is lost
        lines = [ln for ln in p.stdout.splitlines() if ln.startswith("#SBATCH")]
        bad = [ln for ln in lines if "#" in ln[len("#SBATCH"):]
               or len(ln[len("#SBATCH"):].split()) > 2]
        options = {ln[len("#SBATCH"):].split()[0].split("=")[0] for ln in lines}
        fuzz.check(f"[T2] submit --pretend {' '.join(extra)}: one option per #SBATCH",
                   subprocess.CompletedProcess(p.args, p.returncode, p.stdout, ""), {0})
        scripts = p.stdout.split("#!/bin/bash")
        if scripts[0].strip():   # text in front of the #!: sbatch refuses the script
            fuzz.results[-1].verdict = f"text before #!: {scripts[0].strip()[:60]}"
        elif bad or not {"--nodes", "--cpus-per-task"} <= options:
            fuzz.results[-1].verdict = f"directives lost: {bad[:1] or sorted(options)}"


def plot_and_collect(fuzz: Fuzz) -> None:
    """[T3] a plot under way and a collect that changes the tables exclude each other."""
    d = fuzz.sweep_copy()
    plot = subprocess.Popen([BKFLOW, "plot", str(d)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    coll = bk("collect", d, "--analysis", "slip_threshold=0.02")
    plot.communicate(timeout=600)
    fuzz.check("[T3] collect --analysis while a plot draws", coll, {0, 3})
    rec = d / "figures" / "figures.json"
    if rec.exists():
        r = json.loads(rec.read_text())
        from bkflow.store.tables import tables_digest

        if r.get("complete") and r.get("tables_sha256") == tables_digest(d) and not all(
                (d / "figures" / f).is_file() for f in r.get("files", [])):
            fuzz.results[-1].verdict = "figures.json current, its files missing"


def partial_sets(fuzz: Fuzz) -> None:
    """[T4]-[T6] a set changed in part, cut derived files, damage the command repairs."""
    d = fuzz.sweep_copy()
    (d / "runs.csv").write_text((d / "runs.csv").read_text().rsplit("\n", 2)[0] + "\n")
    fuzz.check("[T4] plot of a sweep whose runs.csv is from another collect",
               bk("plot", d), {2})
    fuzz.check("[T4] the collect it names repairs it", bk("collect", d), {0})
    for damage in ("clusters.csv cut", "events.parquet cut, events.csv empty",
                   "summary.json of another analysis"):
        d = fuzz.sweep_copy()
        job = sorted((d / "workspace").iterdir())[0]
        if damage.startswith("clusters"):
            f = job / "clusters.csv"
            if not f.exists():
                f.write_text("event,t\n1,")
            else:
                f.write_text(f.read_text()[: len(f.read_text()) // 2])
        elif damage.startswith("events"):
            data = (job / "events.parquet").read_bytes()
            (job / "events.parquet").write_bytes(data[: len(data) // 2])
            (job / "events.csv").write_text("")
        else:
            s = json.loads((job / "summary.json").read_text())
            s["mu_bar"] = 0.5
            (job / "summary.json").write_text(json.dumps(s))
        fuzz.check(f"[T5/T6] collect of a sweep with a job's {damage}", bk("collect", d),
                   {0})


def foreign_companion(fuzz: Fuzz) -> None:
    """[T7] a companion that is not the run's."""
    pair = fuzz.scratch()
    bk("run", "--phi", "10", "--size", "12x3", "--t-end", "600", "--scene", "friction",
       "--quiet", "--out", pair / "run")
    bk("run", "--phi", "10", "--size", "12x3", "--t-end", "600", "--scene", "friction",
       "--protocol", "paper", "--start", "random", "--quiet", "--out", pair / "other")
    for stand_in in ("a run from the main run's start", "the main run itself",
                     "a symbolic link to another run"):
        d = fuzz.scratch() / "run"
        shutil.copytree(pair / "run", d)
        shutil.rmtree(d / "companion")
        if stand_in.startswith("a symbolic"):
            (d / "companion").symlink_to(pair / "other")
        else:
            src = pair / "other" if stand_in.startswith("a run") else pair / "run"
            shutil.copytree(src, d / "companion", ignore=shutil.ignore_patterns("companion"))
        fuzz.check(f"[T7] analyze with companion/ replaced by {stand_in}",
                   bk("analyze", d), {2})


def api_errors(fuzz: Fuzz) -> None:
    """[T8] the API's errors are the CLI's."""
    # the sweep's catalogue is made from its runs' own (workspace/JOB/events.parquet)
    d = fuzz.sweep_copy()
    cat = sorted((d / "workspace").iterdir())[0] / "events.parquet"
    cat.write_bytes(cat.read_bytes()[:100])
    code = ("import sys\nfrom bkflow.api import load_sweep\ntry:\n"
            f"    load_sweep({str(d)!r}).events\nexcept Exception as e:\n"
            "    print(type(e).__name__, file=sys.stderr); sys.exit(2)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    fuzz.check("[T8] load_sweep().events of a run's cut events.parquet", p, {2})
    if p.stderr.strip() not in ("StaleTablesError", "DamagedRunError"):
        fuzz.results[-1].verdict = f"raised {p.stderr.strip()[:60]}"


def set_checks(fuzz: Fuzz) -> None:
    """[T9] --set goes through the option's checks."""
    for args in (["--set", "companion=partial"], ["--set", "until_steady=true"],
                 ["--set", "target_error=1e-3"], ["--set", "dt_factor=5"]):
        out = fuzz.scratch() / "deck"
        fuzz.check(f"[T9] deck {' '.join(args)}", bk("deck", "--phi", "10", *args,
                                                     "--out", out), {2})


def advice(fuzz: Fuzz) -> None:
    """[T10] the advice names what was changed."""
    d = fuzz.scratch() / "deck"
    bk("deck", "--phi", "10", "--t-end", "50", "--out", d)
    text = (d / "in.bk").read_text()
    import re

    (d / "in.bk").write_text(re.sub(r"(?m)^run( +)\d+", r"run\g<1>100", text))
    (d / "extrema.npy").write_bytes(b"")   # lmp -in in.bk has begun its records
    p = bk("analyze", d)
    fuzz.check("[T10] analyze after in.bk was edited", p, {2})
    if "in.bk was edited" not in p.stderr:
        fuzz.results[-1].verdict = "advice not about in.bk"
    d = fuzz.sweep_copy()
    from signac.job import calc_id

    job = sorted((d / "workspace").iterdir())[0]
    point = json.loads((job / "signac_statepoint.json").read_text())
    point["phi"] = -1.0
    (job / "signac_statepoint.json").write_text(json.dumps(point))
    job.rename(job.with_name(calc_id(point)))
    for env in ("StandardEnvironment", "NoSuchEnvironment"):
        p = subprocess.run([sys.executable, "-m", "bkflow.slurm", "status"], cwd=d,
                           capture_output=True, text=True, timeout=120,
                           env={**os.environ, "SIGNAC_FLOW_ENVIRONMENT": env})
        fuzz.check(f"[T10] cluster status of a rehashed state point phi = -1 ({env})", p,
                   {2})
        if "no working scheduler" in p.stderr:
            fuzz.results[-1].verdict = "blamed the scheduler"


def paste_safe(fuzz: Fuzz) -> None:
    """[T11] printed commands are safe to paste."""
    for name in ("g $(touch PWNED)", "-x", "a'b; touch PWNED"):
        d = fuzz.scratch()
        p = subprocess.run([BKFLOW, "sweep", "--phi", "10", "--seeds", "1",
                            f"--out={name}", "--init"], cwd=d, capture_output=True,
                           text=True, timeout=120)
        fuzz.check(f"[T11] sweep --init into {name!r}: the printed cd, pasted", p, {0})
        if "(cd " in p.stdout:
            cd = p.stdout.split("(cd ", 1)[1].split(" && ", 1)[0]
            sh = subprocess.run(["bash", "-c", f"cd {cd} && pwd -P"], cwd=d,
                                capture_output=True, text=True)
            if sh.stdout.strip() != str((d / name).resolve()) or list(d.rglob("PWNED")):
                fuzz.results[-1].verdict = f"pasted, it did something else: {cd}"


def planted_mark(fuzz: Fuzz) -> None:
    """[T12] a planted mark replaces nothing."""
    for mark in ("", '{"bkflow": "0", "began": 0}'):
        d = fuzz.scratch() / "mine"
        d.mkdir()
        (d / "stress.csv").write_text("my measurements\n")
        os.utime(d / "stress.csv", (time.time() - 3600,) * 2)
        (d / ".bkflow-run").write_text(mark)
        kind = "empty" if not mark else "older stress.csv"
        fuzz.check(f"[T12] run into a directory with a planted mark ({kind})",
                   bk("run", "--phi", "10", *SHORT, "--out", d), {2})
        if (d / "stress.csv").read_text() != "my measurements\n":
            fuzz.results[-1].verdict = "replaced the user's stress.csv"


def fresh_attack(fuzz: Fuzz) -> None:
    """What a fresh attack (a helper who had not read the change) found, each a case."""
    d = fuzz.sweep_copy()
    fig = d / "figures"
    bk("plot", d)
    rec = json.loads((fig / "figures.json").read_text())
    rec["files"].append("/tmp/x")
    (fig / "figures.json").write_text(json.dumps(rec))
    fuzz.check("[F] plot past a figures.json naming an absolute path", bk("plot", d), {0})
    d = fuzz.sweep_copy()
    (d / ".signac" / "config").unlink()
    fuzz.check("[F] collect of a sweep without .signac/config", bk("collect", d), {2})
    for name in ("summary.json", "meta.json"):
        d = fuzz.sweep_copy()
        job = sorted((d / "workspace").iterdir())[0]
        (job / name).unlink()
        os.mkfifo(job / name)
        try:
            p = bk("collect", d, timeout=60)
        except subprocess.TimeoutExpired:
            fuzz.results.append(Result(f"[F] collect with a FIFO as a run's {name}", None,
                                       "", "hung"))
            continue
        fuzz.check(f"[F] collect with a FIFO as a run's {name}", p, {0, 2})
    m = fuzz.scratch() / "m"
    m.mkdir()
    (m / "stress.csv").write_text("MY DATA\n")
    shutil.copy(fuzz.base / ".bkflow-run", m / ".bkflow-run")
    fuzz.check("[F] run into a folder with a copied .bkflow-run mark",
               bk("run", "--phi", "10", *SHORT, "--out", m), {2})
    if (m / "stress.csv").read_text() != "MY DATA\n":
        fuzz.results[-1].verdict = "replaced the user's stress.csv"
    out = fuzz.scratch() / "v"
    fuzz.check("[F] sweep --vary until_steady=true,false (steady protocol)",
               bk("sweep", "--phi", "1", "--vary", "until_steady=true,false", "--out", out),
               {2})
    fuzz.check("[F] run --protocol paper --companion partial --target-error 1e-3",
               bk("run", "--phi", "1", "--size", "12x3", "--protocol", "paper",
                  "--companion", "partial", "--target-error", "1e-3", "--t-end", "300",
                  "--scene", "friction", "--quiet", "--out", fuzz.scratch() / "r"), {0})
    fuzz.check("[F] run --out /proc/x", bk("run", "--phi", "10", *SHORT, "--out",
                                          "/proc/x"), {4})
