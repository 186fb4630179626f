"""The cases of processes that meet each other or are stopped: two writers of one directory,
a disk that fills, interrupts and signals ([1], [13]), a reader of a pipe that goes away, and
requests too large to plan ([2]).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time

from benchmarks.checks.faults.fuzz import SHORT, Fuzz, bk, complete
from benchmarks.harness import BKFLOW


def children(pid: int) -> list[int]:
    """The process ids of the children of ``pid``."""
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True)
    return [int(x) for x in out.stdout.split()]


def hangup_as_in_a_terminal() -> None:
    """A child's SIGHUP as a terminal session has it (the default: it ends the process), even
    where the fuzz itself runs under nohup, whose ignored SIGHUP every child would inherit:
    bkflow keeps an ignored SIGHUP ignored (a sweep under nohup outlives the hangup), so the
    SIGHUP cases would measure nohup, not bkflow."""
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


def sweep_args(out, *extra):
    """A sweep's arguments whose runs last long enough to be signalled while they run."""
    # runs of several seconds each (the small step), so that the signal meets them running
    return ["sweep", "--phi", "300,1000", "--seeds", "2", "--t-end", "3000", "--dt-factor",
            "0.02", "--protocol", "paper", "--scene", "friction", "--jobs", "2", "--quiet",
            "--out", str(out), *extra]


def writers(fuzz: Fuzz) -> None:
    """Two runs, and two sweeps, into one directory: the second is refused (exit 3)."""
    d = fuzz.scratch()
    # a run that lasts well beyond the second's start (the small step: at the default
    # preset's step this run takes less than the 3 s the second waits)
    first = subprocess.Popen([BKFLOW, "run", "--phi", "1000", "--n", "400", "--t-end",
                              "1000", "--dt-factor", "0.05", "--quiet", "--out",
                              str(d / "r")],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(3)
    second = bk("run", "--phi", "1000", "--n", "400", "--t-end", "1000", "--dt-factor",
                "0.05", "--quiet", "--out", d / "r")
    out, err = first.communicate(timeout=600)
    fuzz.check("two runs into one --out: the second", second, {3})
    if first.returncode != 0 or not complete(d / "r"):
        fuzz.results[-1].verdict = f"the first failed: {err.strip()[:80]}"
    args = ["sweep", "--phi", "1,3,10,30", "--seeds", "1", "--t-end", "1000", "--scene",
            "friction", "--jobs", "1", "--quiet", "--out", str(d / "s")]
    a = subprocess.Popen([BKFLOW, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    time.sleep(0.3)
    b = bk(*args)
    a.communicate(timeout=600)
    fuzz.check("two sweeps on a new directory: the second", b, {3})
    if a.returncode != 0:
        fuzz.results[-1].verdict = "the first sweep failed"


def disk_full(fuzz: Fuzz) -> None:
    """A disk too small for the estimate, one that fills during the run and during the
    analysis."""
    d = fuzz.scratch()
    small = d / "small"
    if not fuzz.tmpfs(small, "size=400k"):
        fuzz.skip("full disk during the run", "mount not allowed here")
        return
    try:
        # the scene that keeps the raw series (stress.npy, phase.npy: some 700 kB here);
        # the friction scene's records fit the small disk
        fuzz.check("disk too small for the estimate: refused before starting",
                   bk("run", "--phi", "10", "--t-end", "2000", "--scene", "series",
                      "--quiet", "--out", small / "r"), {2}, [small / "r"])
        fuzz.check("--force: the disk fills during the run",
                   bk("run", "--phi", "10", "--t-end", "2000", "--scene", "series",
                      "--quiet", "--force", "--out", small / "r"), {4}, [small / "r"])
        shutil.rmtree(small / "r", ignore_errors=True)
        # a run that fits, whose analysis does not: fill the disk after the run
        # (the paper's protocol: one run, no companion, so that it fits the small disk)
        p = bk("run", "--phi", "10", "--t-end", "300", "--scene", "friction", "--quiet",
               "--protocol", "paper", "--no-analyze", "--out", small / "a")
        assert p.returncode == 0, p.stderr
        free = shutil.disk_usage(small).free
        (small / "filler").write_bytes(b"\0" * max(0, free - 2048))
        p = bk("analyze", small / "a")
        fuzz.check("full disk during the analysis", p, {4})
        if any(n.endswith(".tmp") for n in os.listdir(small / "a")):
            fuzz.results[-1].verdict = "left a .tmp file"
        (small / "filler").unlink()
        p = bk("run", "--phi", "10", "--t-end", "300", "--scene", "friction", "--quiet",
               "--protocol", "paper", "--out", small / "a")
        fuzz.check("same command after freeing space: analyses only", p, {0})
        if "finished earlier; analysing" not in p.stdout:
            fuzz.results[-1].verdict = "ran again instead of analysing"
    finally:
        subprocess.run(["umount", str(small)])


def interrupts(fuzz: Fuzz) -> None:
    """Ctrl-C mid-run, the same command after it, and a run that tears whatever the step."""
    d = fuzz.scratch()
    p = subprocess.Popen([BKFLOW, "run", "--phi", "1000", "--n", "900", "--t-end", "20000",
                          "--dt-factor", "0.1", "--out", str(d / "r"), "--quiet"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(5)
    t0 = time.time()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    waited = time.time() - t0
    proc = subprocess.CompletedProcess(p.args, p.returncode, out, err)
    fuzz.check(f"Ctrl-C mid-run (exited after {waited:.2f} s)", proc, {130}, [d / "r"])
    if waited > 1.0:
        fuzz.results[-1].verdict = f"took {waited:.2f} s"
    p = bk("run", "--phi", "10", *SHORT, "--out", d / "r")
    fuzz.check("the same command after Ctrl-C redoes the run", p, {0})
    tear = bk("run", "--phi", "0.01", "--t-end", "2000", "--scene", "friction", "--quiet",
              "--out", d / "t")
    fuzz.check("phi = 0.01 tears whatever dt", tear, {1}, [d / "t"])
    if "whatever the time step" not in tear.stderr:
        fuzz.results[-1].verdict = "advice is not the physics"


def pipes(fuzz: Fuzz) -> None:
    """Output into a pipe whose reader goes away."""
    for case, args in (("run --help | head -1", ["run", "--help"]),
                       ("collect | head -1", ["collect", str(fuzz.sweep)])):
        p = subprocess.run(f"{BKFLOW} {' '.join(args)} | head -1", shell=True,
                           capture_output=True, text=True)
        proc = subprocess.CompletedProcess(p.args, 0 if "Traceback" not in p.stderr else 1,
                                           p.stdout, p.stderr)
        fuzz.check(f"pipe: {case}", proc, {0})


def hangs(fuzz: Fuzz) -> None:
    """[1] a signal to a sweep's worker or to the sweep: it ends, and the same command
    finishes it."""
    for target, sig in (("worker", signal.SIGKILL), ("worker", signal.SIGTERM),
                        ("sweep", signal.SIGTERM), ("sweep", signal.SIGHUP)):
        d = fuzz.scratch() / "s"
        args = sweep_args(d)
        p = subprocess.Popen([BKFLOW, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, preexec_fn=hangup_as_in_a_terminal)
        deadline = time.time() + 120
        while time.time() < deadline and not list((d / "workspace").glob("*/extrema.npy")):
            time.sleep(0.1)
        time.sleep(0.5)
        kids = children(p.pid)
        if target == "worker" and not kids:   # the case did not happen: say so
            p.communicate(timeout=600)
            fuzz.skip(f"[1] {signal.Signals(sig).name} to a worker of a sweep",
                      "no worker was running when the signal was due")
            continue
        os.kill(kids[0] if target == "worker" else p.pid, sig)
        t0 = time.time()
        try:
            out, err = p.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            p.kill()
            out, err = p.communicate()
        waited = time.time() - t0
        name = signal.Signals(sig).name
        fuzz.check(f"[1] {name} to a {target} of a sweep (exited after {waited:.1f} s)",
                   subprocess.CompletedProcess(p.args, p.returncode, out, err),
                   {1} if target == "worker" else {130})
        if waited > (30 if target == "worker" else 5):
            fuzz.results[-1].verdict = f"took {waited:.1f} s"
        again = bk(*args, timeout=600)
        fuzz.check(f"[1] ... the same command after {name} finishes", again, {0})


def absurd_grids(fuzz: Fuzz) -> None:
    """[2] requests too large to plan are refused before any work."""
    for case, args in (("--seeds 100000000", ["--phi", "1", "--seeds", "100000000"]),
                       ("--points-per-decade 100000000", ["--phi", "1:10",
                                                          "--points-per-decade",
                                                          "100000000"]),
                       ("--phi 1e-200:1e200", ["--phi", "1e-200:1e200"]),
                       ("--phi 1e-300:1e300 at 1 per decade",
                        ["--phi", "1e-300:1e300", "--points-per-decade", "1"]),
                       ("--vary gamma with 3000 values x 301 phi",
                        ["--phi", "1:1000", "--points-per-decade", "100", "--vary",
                         "gamma=" + ",".join(f"{0.1 + k * 1e-4:.4f}"
                                             for k in range(3000))])):
        out = fuzz.scratch() / "s"
        t0 = time.time()
        p = bk("sweep", *args, "--init", "--out", out)
        waited = time.time() - t0
        fuzz.check(f"[2] {case} (refused in {waited:.1f} s)", p, {2}, [out])
        if waited > 10 or out.exists():
            fuzz.results[-1].verdict = f"took {waited:.1f} s" if waited > 10 else \
                "created the sweep directory"


def signals(fuzz: Fuzz) -> None:
    """[13] a signal to a run after MPI loaded ends it as Ctrl-C does."""
    for sig in (signal.SIGHUP, signal.SIGTERM, signal.SIGINT):
        d = fuzz.scratch()
        p = subprocess.Popen([BKFLOW, "run", "--phi", "1000", "--n", "900", "--t-end",
                              "20000", "--out", str(d / "r"), "--quiet"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             preexec_fn=hangup_as_in_a_terminal)
        deadline = time.time() + 60
        while not (d / "r" / "extrema.npy").exists() and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)
        t0 = time.time()
        p.send_signal(sig)
        out, err = p.communicate(timeout=60)
        waited = time.time() - t0
        name = signal.Signals(sig).name
        fuzz.check(f"[13] {name} to a run after MPI loaded (exited after {waited:.2f} s)",
                   subprocess.CompletedProcess(p.args, p.returncode, out, err), {130},
                   [d / "r"])
        if waited > 1.0:
            fuzz.results[-1].verdict = f"took {waited:.2f} s"
