"""Fuzz bkflow with bad inputs and faults: every one must end CLEAN.

    python -m benchmarks.checks.faults [--keep DIR]

Runs each case as a user would (the ``bkflow`` command, in a scratch directory) and prints a
table: case, exit code, the first line of stderr, verdict. A case is CLEAN when

- the exit code is the one expected (README, "Exit codes"),
- stderr has no traceback and, on failure, exactly one line (a warning line may precede it),
- nothing finished changed: a finished run and a finished sweep made at the start keep every
  byte of every file, and no directory the case wrote into looks finished unless it is.

Some cases need root (a read-only and a full file system are tmpfs mounts); they are listed
as SKIPPED where mounting is not allowed. The classes are those of the faults issues: paths,
cut files, two writers, file-system errors, damaged inputs, absurd requests, wrong advice,
and interrupts; then the second round, each case named by its class: [1] hangs (a dead
worker), [2] work before the limits, [3] a sweep into the user's files, [4] a deck over the
user's, [5] figures and movies written whole or not at all, [6] parameter domains, [7] the
environment named, not blamed on the run, [8] one analysis per figure set, [9] lmp -in in a
finished run, [10] options and counts, [11] a hand-edited workspace, [12] other tracebacks,
[13] signals, [14] the documented commands; and the third round's, [T1] nothing outside the
directory touched, [T2] job scripts as Slurm reads them, [T3] a stale record marked current,
[T4] a set changed in part, [T5] cut derived files, [T6] damage the command repairs, [T7] a
foreign companion, [T8] the API's errors, [T9] --set through the options' checks, [T10] the
advice, [T11] printed commands safe to paste, [T12] a planted mark; and the fourth round's
[F1]-[F18] (benchmarks/checks/faults/records.py).

    python -m benchmarks.checks.faults --only third_round     # one part (a method's name)
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from benchmarks.harness import BKFLOW, RECORDS, ROOT, parser

#: the record of the last whole fuzz (benchmarks/RESULTS.md's table is generated from it)
RECORD = RECORDS / "faults.json"
SHORT = ["--t-end", "100", "--scene", "friction", "--quiet"]


@dataclass
class Result:
    case: str
    code: int | None
    first: str
    verdict: str


def bk(*args, cwd=None, timeout=300, **kw):
    return subprocess.run([BKFLOW, *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=timeout, **kw)


def digest(root: Path) -> dict:
    out = {}
    for p in sorted(root.rglob("*")):
        if p.is_file() and not p.name.endswith(".lock"):
            out[str(p.relative_to(root))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def row_cut(data: bytes) -> int:
    """Where a .npy file holding half its rows whole ends: its header and rows up to the
    middle (a binary table's cut at a line)."""
    import io

    import numpy as np

    f = io.BytesIO(data)
    version = np.lib.format.read_magic(f)
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else \
        np.lib.format.read_array_header_2_0
    shape, _, dtype = read(f)
    row = dtype.itemsize * int(np.prod(shape[1:], dtype=int))
    return f.tell() + (shape[0] // 2 if shape else 0) * row


def complete(d: Path) -> bool:
    try:
        return json.loads((d / "meta.json").read_text()).get("status") == "complete"
    except (OSError, ValueError):
        return False


class Fuzz:
    def __init__(self, root: Path):
        self.root = root
        self.results: list[Result] = []
        self.base = root / "base"          # a finished run nothing may change
        self.sweep = root / "sweep"        # a finished sweep nothing may change
        # the full scene: every derived file (fronts for the movie, the ledger) exists
        p = bk("run", "--phi", "10", "--t-end", "200", "--scene", "full", "--out", self.base,
               "--quiet")
        assert p.returncode == 0, p.stderr
        p = bk("sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--scene", "friction",
               "--jobs", "2", "--out", self.sweep, "--quiet")
        assert p.returncode == 0, p.stderr
        self.before = {d: digest(d) for d in (self.base, self.sweep)}
        self.n = 0

    @staticmethod
    def tmpfs(where: Path, options: str) -> bool:
        """Mount a tmpfs at ``where`` (root only); False where mounting is not allowed."""
        where.mkdir(parents=True, exist_ok=True)
        return subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)],
                              capture_output=True).returncode == 0

    def scratch(self) -> Path:
        self.n += 1
        d = self.root / f"case{self.n:03d}"
        d.mkdir()
        return d

    def check(self, case: str, proc, expected, not_finished=(), note="") -> None:
        code = proc.returncode if proc is not None else None
        err = (proc.stderr if proc is not None else "") or ""
        lines = [ln for ln in err.strip().splitlines() if ln.strip()]
        problems = []
        if code not in expected:
            problems.append(f"exit {code}, expected {sorted(expected)}")
        if "Traceback" in err:
            problems.append("traceback")
        if code not in (0, None) and len([ln for ln in lines if "warning" not in ln]) != 1:
            problems.append(f"{len(lines)} stderr lines")
        for d in self.before:
            if digest(d) != self.before[d]:
                problems.append(f"{d.name} changed")
                self.before[d] = digest(d)
        for d in not_finished:
            if complete(Path(d)):
                problems.append(f"{Path(d).name} looks finished")
        first = lines[-1] if lines else (proc.stdout.strip().splitlines()[:1] or [""])[0] \
            if proc is not None else note
        self.results.append(Result(case, code, first[:110],
                                   "CLEAN" if not problems else "; ".join(problems)))

    def skip(self, case: str, why: str) -> None:
        self.results.append(Result(case, None, why, "SKIPPED"))

    # ------------------------------------------------------------------ the cases
    def arguments(self):
        bad_run = {
            "phi 0": ["--phi", "0"], "phi -1": ["--phi", "-1"], "phi nan": ["--phi", "nan"],
            "phi inf": ["--phi", "inf"], "phi abc": ["--phi", "abc"],
            "phi 1e12 (8e12 atom-steps)": ["--phi", "1e12"],
            "size 2x5": ["--phi", "1", "--size", "2x5"],
            "size 20by5": ["--phi", "1", "--size", "20by5"],
            "size 0x0": ["--phi", "1", "--size", "0x0"],
            "size 100000x25000 (2.5e9 atoms)": ["--phi", "1", "--size", "100000x25000"],
            "size 40000x10000 (800 GB)": ["--phi", "1", "--size", "40000x10000"],
            "n 500": ["--phi", "1", "--n", "500"],
            "t-end 0": ["--phi", "1", "--t-end", "0"], "t-end -5": ["--phi", "1", "--t-end", "-5"],
            "t-end 1e300": ["--phi", "1", "--t-end", "1e300"],
            "t-end nan": ["--phi", "1", "--t-end", "nan"],
            "dt-factor 5": ["--phi", "1", "--dt-factor", "5"],
            "dt-factor 0": ["--phi", "1", "--dt-factor", "0"],
            "seed -1": ["--phi", "1", "--seed", "-1"],
            "target-error -1": ["--phi", "1", "--target-error", "-1"],
            "accuracy bogus": ["--phi", "1", "--accuracy", "bogus"],
            "contact-rule sticky": ["--phi", "1", "--contact-rule", "sticky"],
            "scene foo": ["--phi", "1", "--scene", "foo"],
            "start hot": ["--phi", "1", "--start", "hot"],
            "no --phi": [], "unknown option": ["--phi", "1", "--frobnicate"],
        }
        for case, args in bad_run.items():
            out = self.scratch() / "out"
            self.check(f"run: {case}", bk("run", *args, "--out", out), {2}, [out])
            if out.exists():
                self.results[-1].verdict = "created the output directory"
        out = self.scratch() / "o"
        self.check("deck: --until-steady", bk("deck", "--phi", "1", "--until-steady",
                                                  "--out", out), {2})
        bad_sweep = {
            "phi 1e3:1e-1": ["--phi", "1e3:1e-1"], "phi 0:1": ["--phi", "0:1"],
            "phi a:b": ["--phi", "a:b"], "phi 1:2:3": ["--phi", "1:2:3"],
            "sizes 7x3": ["--phi", "1", "--sizes", "7x3"],
            "sizes 8x2": ["--phi", "1", "--sizes", "8x2"],
            "jobs 0": ["--phi", "1", "--jobs", "0"], "jobs 1000": ["--phi", "1", "--jobs", "1000"],
            "seeds 0": ["--phi", "1", "--seeds", "0"],
            "points-per-decade 0": ["--phi", "1:10", "--points-per-decade", "0"],
            "points-per-decade 1e6 (2e6 runs)": ["--phi", "1:10", "--points-per-decade",
                                                 "1000000", "--init"],
            "aspect 0": ["--phi", "1", "--aspect", "0"],
            "analysis s_x=-1": ["--phi", "1", "--analysis", "s_x=-1"],
            "analysis foo=1": ["--phi", "1", "--analysis", "foo=1"],
        }
        for case, args in bad_sweep.items():
            out = self.scratch() / "s"
            self.check(f"sweep: {case}", bk("sweep", *args, "--out", out), {2})
            if out.exists():
                self.results[-1].verdict = "created the sweep directory"

    def paths(self):
        for name in ("with space", "hash#mark", "dollar$HOME", "quote'single", 'quote"double',
                     "ünïcødé ß"):
            d = self.scratch() / name
            d.mkdir()
            p = bk("run", "--phi", "10", *SHORT, "--out", "r", cwd=d)
            ok = p.returncode == 0 and complete(d / "r")
            self.check(f"path: cwd and --out with {name}", p, {0})
            if not ok:
                self.results[-1].verdict = "run did not finish"

    def directories(self):
        d = self.scratch()
        (d / "file").write_text("x")
        self.check("out is an existing file", bk("run", "--phi", "10", *SHORT, "--out",
                                                 d / "file"), {2, 4})
        self.check("out below a file", bk("run", "--phi", "10", *SHORT, "--out",
                                          d / "file" / "r"), {4})
        self.check("name too long", bk("run", "--phi", "10", *SHORT, "--out", d / ("n" * 300)),
                   {4})
        f = d / "foreign"
        f.mkdir()
        (f / "notes.txt").write_text("mine")
        self.check("out holds foreign files", bk("run", "--phi", "10", *SHORT, "--out", f), {2})
        assert (f / "notes.txt").read_text() == "mine"
        deck = d / "deck"
        bk("deck", "--phi", "10", "--out", deck)
        self.check("run into a deck directory", bk("run", "--phi", "10", *SHORT, "--out", deck),
                   {2})
        lmp = d / "standalone"
        bk("deck", "--phi", "10", "--t-end", "50", "--scene", "friction", "--out", lmp)
        subprocess.run([str(Path(sys.executable).with_name("lmp")), "-in", "in.bk", "-screen",
                        "none", "-var", "comm_cutoff", "1.0"], cwd=lmp, check=True)
        snap = digest(lmp)
        self.check("run into a finished lmp run", bk("run", "--phi", "10", *SHORT, "--out", lmp),
                   {2})
        if digest(lmp) != snap:
            self.results[-1].verdict = "changed the lmp run"
        self.check("run into a finished run", bk("run", "--phi", "10", "--t-end", "200",
                                                 "--out", self.base), {2})
        self.check("deck into a finished run", bk("deck", "--phi", "10", "--out", self.base),
                   {2})
        ro = d / "ro"
        if self.tmpfs(ro, "ro,size=1m"):
            try:
                self.check("read-only file system", bk("run", "--phi", "10", *SHORT, "--out",
                                                       ro / "r"), {4})
            finally:
                subprocess.run(["umount", str(ro)])
        else:
            self.skip("read-only file system", "mount not allowed here")

    def disk_full(self):
        d = self.scratch()
        small = d / "small"
        if not self.tmpfs(small, "size=400k"):
            self.skip("full disk during the run", "mount not allowed here")
            return
        try:
            # the scene that keeps the raw series (stress.npy, phase.npy: some 700 kB here);
            # the friction scene's records fit the small disk
            self.check("disk too small for the estimate: refused before starting",
                       bk("run", "--phi", "10", "--t-end", "2000", "--scene", "series",
                          "--quiet", "--out", small / "r"), {2}, [small / "r"])
            self.check("--force: the disk fills during the run",
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
            self.check("full disk during the analysis", p, {4})
            if any(n.endswith(".tmp") for n in os.listdir(small / "a")):
                self.results[-1].verdict = "left a .tmp file"
            (small / "filler").unlink()
            p = bk("run", "--phi", "10", "--t-end", "300", "--scene", "friction", "--quiet",
                   "--protocol", "paper", "--out", small / "a")
            self.check("same command after freeing space: analyses only", p, {0})
            if "finished earlier; analysing" not in p.stdout:
                self.results[-1].verdict = "ran again instead of analysing"
        finally:
            subprocess.run(["umount", str(small)])

    def damaged(self):
        def copy():
            d = self.scratch() / "run"
            shutil.copytree(self.base, d)
            return d

        self.check("analyze: no such directory", bk("analyze", self.root / "nowhere"), {2})
        self.check("analyze: empty directory", bk("analyze", self.scratch()), {2})
        d = copy()
        meta = json.loads((d / "meta.json").read_text())
        del meta["params"]
        (d / "meta.json").write_text(json.dumps(meta))
        self.check("analyze: meta.json without params", bk("analyze", d), {2})
        d = copy()
        (d / "meta.json").write_text("{not json")
        self.check("analyze: meta.json not JSON", bk("analyze", d), {2})
        d = self.scratch() / "deck"
        bk("deck", "--phi", "10", "--out", d)
        for name in ("extrema.npy", "blocks.npy"):   # the records lmp -in in.bk would write
            shutil.copy(self.base / name, d / name)
        (d / "params.json").write_text("[1, 2, 3]")
        self.check("analyze: params.json of the wrong shape", bk("analyze", d), {2})
        (d / "params.json").write_text('{"phi": "ten"}')
        self.check("analyze: params.json with a bad value", bk("analyze", d), {2})
        # the stress as the full scene keeps it: its records (extrema.npy, blocks.npy) and the
        # raw series (stress.npy), each cut after a whole row and in the middle of one
        for name, cut in (("extrema.npy", "row"), ("extrema.npy", "middle"),
                          ("blocks.npy", "row"), ("blocks.npy", "middle"),
                          ("stress.npy", "row"), ("stress.npy", "middle"),
                          ("slips.lammpstrj", "middle"), ("snapshots.lammpstrj", "middle")):
            d = copy()
            data = (d / name).read_bytes()
            at = row_cut(data) if cut == "row" else len(data) // 2
            (d / name).write_bytes(data[:at])
            before = (d / "summary.json").read_bytes()
            self.check(f"analyze: {name} cut at a {cut}", bk("analyze", d), {2})
            if (d / "summary.json").read_bytes() != before:
                self.results[-1].verdict = "rewrote the summary of a damaged run"
        for name in ("extrema.npy", "stress.npy"):
            d = copy()
            (d / name).write_bytes(b"\x00garbage" * 10)
            self.check(f"analyze: {name} replaced by garbage", bk("analyze", d), {2})
        d = copy()
        (d / "summary.json").write_text('{"mu_bar": 0.1')
        self.check("analyze: cut summary.json is redone", bk("analyze", d), {0})
        self.check("collect: not a sweep", bk("collect", self.scratch()), {2})
        self.check("plot: not a sweep", bk("plot", self.scratch()), {2})
        self.check("plot: unknown format", bk("plot", self.sweep, "--out", self.scratch(),
                                              "--format", "jpgx"), {2})
        self.check("plot: --where on no column", bk("plot", self.sweep, "--out", self.scratch(),
                                                    "--where", "nosuch=1"), {2})

    def writers(self):
        d = self.scratch()
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
        self.check("two runs into one --out: the second", second, {3})
        if first.returncode != 0 or not complete(d / "r"):
            self.results[-1].verdict = f"the first failed: {err.strip()[:80]}"
        args = ["sweep", "--phi", "1,3,10,30", "--seeds", "1", "--t-end", "1000", "--scene",
                "friction", "--jobs", "1", "--quiet", "--out", str(d / "s")]
        a = subprocess.Popen([BKFLOW, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
        time.sleep(0.3)
        b = bk(*args)
        a.communicate(timeout=600)
        self.check("two sweeps on a new directory: the second", b, {3})
        if a.returncode != 0:
            self.results[-1].verdict = "the first sweep failed"

    def interrupts(self):
        d = self.scratch()
        p = subprocess.Popen([BKFLOW, "run", "--phi", "1000", "--n", "900", "--t-end", "20000",
                              "--dt-factor", "0.1", "--out", str(d / "r"), "--quiet"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(5)
        t0 = time.time()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
        waited = time.time() - t0
        proc = subprocess.CompletedProcess(p.args, p.returncode, out, err)
        self.check(f"Ctrl-C mid-run (exited after {waited:.2f} s)", proc, {130}, [d / "r"])
        if waited > 1.0:
            self.results[-1].verdict = f"took {waited:.2f} s"
        p = bk("run", "--phi", "10", *SHORT, "--out", d / "r")
        self.check("the same command after Ctrl-C redoes the run", p, {0})
        tear = bk("run", "--phi", "0.01", "--t-end", "2000", "--scene", "friction", "--quiet",
                  "--out", d / "t")
        self.check("phi = 0.01 tears whatever dt", tear, {1}, [d / "t"])
        if "whatever the time step" not in tear.stderr:
            self.results[-1].verdict = "advice is not the physics"

    def pipes(self):
        for case, args in (("run --help | head -1", ["run", "--help"]),
                           ("collect | head -1", ["collect", str(self.sweep)])):
            p = subprocess.run(f"{BKFLOW} {' '.join(args)} | head -1", shell=True,
                               capture_output=True, text=True)
            proc = subprocess.CompletedProcess(p.args, 0 if "Traceback" not in p.stderr else 1,
                                               p.stdout, p.stderr)
            self.check(f"pipe: {case}", proc, {0})

    # ------------------------------------------------------------------ round 2 (the classes
    # of the second faults issue, several instances each; the case names say the class)
    def _children(self, pid: int) -> list[int]:
        out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True)
        return [int(x) for x in out.stdout.split()]

    def _sweep_args(self, out, *extra):
        # runs of several seconds each (the small step), so that the signal meets them running
        return ["sweep", "--phi", "300,1000", "--seeds", "2", "--t-end", "3000", "--dt-factor",
                "0.02", "--protocol", "paper", "--scene", "friction", "--jobs", "2", "--quiet",
                "--out", str(out), *extra]

    def hangs(self):
        for target, sig in (("worker", signal.SIGKILL), ("worker", signal.SIGTERM),
                            ("sweep", signal.SIGTERM), ("sweep", signal.SIGHUP)):
            d = self.scratch() / "s"
            args = self._sweep_args(d)
            p = subprocess.Popen([BKFLOW, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 text=True)
            deadline = time.time() + 120
            while time.time() < deadline and not list((d / "workspace").glob("*/extrema.npy")):
                time.sleep(0.1)
            time.sleep(0.5)
            kids = self._children(p.pid)
            if target == "worker" and not kids:   # the case did not happen: say so
                p.communicate(timeout=600)
                self.skip(f"[1] {signal.Signals(sig).name} to a worker of a sweep",
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
            self.check(f"[1] {name} to a {target} of a sweep (exited after {waited:.1f} s)",
                       subprocess.CompletedProcess(p.args, p.returncode, out, err),
                       {1} if target == "worker" else {130})
            if waited > (30 if target == "worker" else 5):
                self.results[-1].verdict = f"took {waited:.1f} s"
            again = bk(*args, timeout=600)
            self.check(f"[1] ... the same command after {name} finishes", again, {0})
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
            out = self.scratch() / "s"
            t0 = time.time()
            p = bk("sweep", *args, "--init", "--out", out)
            waited = time.time() - t0
            self.check(f"[2] {case} (refused in {waited:.1f} s)", p, {2}, [out])
            if waited > 10 or out.exists():
                self.results[-1].verdict = f"took {waited:.1f} s" if waited > 10 else \
                    "created the sweep directory"

    def users_files(self):
        def sweep_into(d, label):
            before = digest(d)
            p = bk("sweep", "--phi", "1", "--seeds", "1", "--t-end", "50", "--scene",
                   "friction", "--out", d)
            self.check(f"[3] sweep --out {label}", p, {2})
            if digest(d) != before:
                self.results[-1].verdict = "changed the user's files"

        for label, files in (("a directory of the user's tables",
                              {"results.csv": "mine", "runs.csv": "mine",
                               "analysis.json": "{}"}),
                             ("a directory of the user's notes", {"notes.txt": "mine"}),
                             ("a foreign signac project",
                              {".signac/config": "schema_version = 2\n",
                               "signac_project_document.json": '{"mine": 1}'})):
            d = self.scratch() / "u"
            for rel, text in files.items():
                (d / rel).parent.mkdir(parents=True, exist_ok=True)
                (d / rel).write_text(text)
            sweep_into(d, label)
        self.check("[3] sweep --out a finished run", bk("sweep", "--phi", "1", "--out",
                                                        self.base), {2})
        for label, edit in (("a hand-written in.bk", None), ("an edited in.bk", "in.bk"),
                            ("an edited data.bk", "data.bk"),
                            ("an edited params.json", "params.json")):
            d = self.scratch() / "deck"
            if edit is None:
                d.mkdir()
                (d / "in.bk").write_text("units lj\n")
            else:
                bk("deck", "--phi", "10", "--out", d)
                (d / edit).write_text((d / edit).read_text().replace("1", "2", 1))
            before = digest(d)
            self.check(f"[4] deck --out over {label}", bk("deck", "--phi", "3", "--out", d),
                       {2})
            if digest(d) != before:
                self.results[-1].verdict = "replaced the user's deck"
        # figures and movies: a signal or a full disk leaves the old file or the new one
        figs = self.scratch() / "figs"
        bk("plot", self.sweep, "--out", figs)
        for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGKILL):
            for delay in (0.8, 1.6):
                p = subprocess.Popen([BKFLOW, "plot", str(self.sweep), "--out", str(figs)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                time.sleep(delay)
                p.send_signal(sig)
                out, err = p.communicate(timeout=60)
                # SIGKILL leaves no chance to clean up: its temporary stays, hidden (.name)
                # and never taken for a figure; the figures themselves must be whole
                bad = [f.name for f in figs.iterdir() if f.suffix in (".png", ".pdf")
                       and not _whole_figure(f)] + [f.name for f in figs.iterdir()
                                                    if f.name.endswith(".tmp")
                                                    and sig != signal.SIGKILL]
                self.check(f"[5] {signal.Signals(sig).name} during plot after {delay} s",
                           subprocess.CompletedProcess(p.args, 0 if not bad else 1, out, err),
                           {0})
                if bad:
                    self.results[-1].verdict = f"left {', '.join(bad[:3])}"
        small = self.scratch() / "small"
        if not self.tmpfs(small, "size=64k"):
            self.skip("[5] full disk during movie", "mount not allowed here")
            return
        try:
            for name in ("slip.gif", "other.gif"):
                p = bk("movie", self.base, "--out", small / name)
                self.check(f"[5] full disk during movie ({name})", p, {4})
                left = [n for n in os.listdir(small) if n.endswith((".gif", ".tmp"))]
                if left:
                    self.results[-1].verdict = f"left {', '.join(left)}"
        finally:
            subprocess.run(["umount", str(small)])

    def misread(self):
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
            out = self.scratch() / "r"
            cmd = "sweep" if args[0] == "--analysis" else "run"
            self.check(f"[6] {cmd} {case}", bk(cmd, "--phi", "10", *SHORT, *args, "--out", out),
                       {2}, [out])
        for case, env, code in (("OMP_NUM_THREADS=4,2 (valid OpenMP)",
                                 {"OMP_NUM_THREADS": "4,2"}, 0),
                                ("OMP_NUM_THREADS=abc", {"OMP_NUM_THREADS": "abc"}, 2),
                                ("OMP_NUM_THREADS=1.5", {"OMP_NUM_THREADS": "1.5"}, 2),
                                ("NUMEXPR_NUM_THREADS=x", {"NUMEXPR_NUM_THREADS": "x"}, 2)):
            d = self.scratch() / "run"
            shutil.copytree(self.base, d)
            p = bk("analyze", d, env={**os.environ, **env})
            self.check(f"[7] analyze with {case}", p, {code})
            if "damaged" in p.stderr:
                self.results[-1].verdict = "called the run damaged"
        import resource

        for limit in (300, 450):
            def cap(mb=limit):
                resource.setrlimit(resource.RLIMIT_AS, (mb * 2**20, mb * 2**20))
            d = self.scratch() / "run"
            shutil.copytree(self.base, d)
            p = bk("analyze", d, preexec_fn=cap)
            self.check(f"[7] analyze under a {limit} MB memory limit", p, {0, 5})
            if "damaged" in p.stderr:
                self.results[-1].verdict = "called the run damaged"
        # analysis settings mixed in one figure set
        from bkflow.analysis.summary import analyze
        from bkflow.model.settings import AnalysisSettings

        for threshold in (0.05, 0.02):
            d = self.scratch() / "s"
            shutil.copytree(self.sweep, d)
            job = sorted((d / "workspace").iterdir())[0]
            analyze(job, AnalysisSettings(slip_threshold=threshold))
            self.check(f"[8] plot after a collect --analysis slip_threshold={threshold} cut "
                       "short", bk("plot", d), {2})
        d = self.scratch() / "s"
        shutil.copytree(self.sweep, d)
        doc = d / "signac_project_document.json"
        data = json.loads(doc.read_text()) if doc.exists() else {}
        data["analysis_settings"] = {"s_x": 0.02}
        doc.write_text(json.dumps(data))
        self.check("[8] plot when the sweep's settings are not its tables'", bk("plot", d), {2})
        # lmp -in inside a finished run
        lmp_bin = str(Path(sys.executable).with_name("lmp"))
        for case, extra in (("a fixed run", []), ("an adaptive pair", ["--size", "12x3",
                                                                      "--target-error", "2e-3",
                                                                      "--protocol", "steady"])):
            d = self.scratch() / "r"
            bk("run", "--phi", "10", "--t-end", "200", *extra, "--quiet", "--out", d)
            for where in (d, d / "companion"):
                if (where / "in.bk").exists():
                    subprocess.run([lmp_bin, "-in", "in.bk", "-screen", "none"], cwd=where,
                                   check=True)
            p = bk("analyze", d)
            self.check(f"[9] analyze after lmp -in in.bk inside {case}", p, {0})
        d = self.scratch() / "s"
        shutil.copytree(self.sweep, d)
        job = sorted((d / "workspace").iterdir())[0]
        subprocess.run([lmp_bin, "-in", "in.bk", "-screen", "none"], cwd=job, check=True)
        p = bk("sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--scene",
               "friction", "--jobs", "2", "--out", d, "--quiet")
        self.check("[9] the sweep after lmp -in in one of its runs", p, {0})
        if "0 run(s) done" not in p.stdout:
            self.results[-1].verdict = "redid a run"

    def options(self):
        for case, args in (("run --over (not --overwrite)",
                            ["run", "--phi", "10", "--t-end", "200", "--over", "--out",
                             self.base]),
                           ("run --overw", ["run", "--phi", "10", "--overw", "--out", self.base]),
                           ("sweep --seed 3", ["sweep", "--phi", "1", "--seed", "3", "--out",
                                               self.scratch() / "s"]),
                           ("sweep --point 3", ["sweep", "--phi", "1:10", "--point", "3",
                                                "--out", self.scratch() / "s"])):
            self.check(f"[10] {case}", bk(*args), {2})
        # a run that another process writes is busy, not failed
        d = self.scratch() / "s"
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
        self.check("[10] a sweep beside a run another process holds", p, {3})
        if "failed" in p.stdout.replace("0 failed", "") or \
                "written by another process" not in p.stdout:
            self.results[-1].verdict = "said failed, or did not say busy"
        p = bk(*args)
        self.check("[10] ... the same command once it is free", p, {0})
        # figures of old tables after a second sweep
        d = self.scratch() / "s"
        shutil.copytree(self.sweep, d)
        bk("plot", d)
        p = bk("sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "150", "--scene",
               "friction", "--jobs", "2", "--out", d, "--quiet")
        left = sorted((d / "figures").glob("*.png")) if (d / "figures").exists() else []
        self.check("[10] figures after a second sweep with another t_end", p, {0})
        if left:
            self.results[-1].verdict = f"left {len(left)} figures of the old tables"

    def workspace(self):
        edits = {
            "an edited state point": lambda d, j: (j / "signac_statepoint.json").write_text(
                (j / "signac_statepoint.json").read_text().replace('"seed": 1', '"seed": 7')),
            "a renamed job folder": lambda d, j: j.rename(j.with_name("f" * 32)),
            "an empty job folder": lambda d, j: (d / "workspace" / ("0" * 32)).mkdir(),
            "a missing signac_statepoint.json": lambda d, j: (
                j / "signac_statepoint.json").unlink(),
            "a cut job document": lambda d, j: (j / "signac_job_document.json").write_text(
                '{"err'),
            "a cut project document": lambda d, j: (
                d / "signac_project_document.json").write_text('{"ana'),
            "junk in .signac/config": lambda d, j: (d / ".signac" / "config").write_text(
                "junk!!\n"),
        }
        for case, edit in edits.items():
            d = self.scratch() / "s"
            shutil.copytree(self.sweep, d)
            edit(d, sorted((d / "workspace").iterdir())[0])
            for cmd in (["collect", d], ["sweep", "--phi", "1,10", "--seeds", "1", "--t-end",
                                         "100", "--scene", "friction", "--out", d]):
                self.check(f"[11] {cmd[0]} with {case}", bk(*cmd), {2})

    def tracebacks(self):
        d = self.scratch() / "vg"
        bk("sweep", "--phi", "1", "--seeds", "1", "--t-end", "100", "--scene", "friction",
           "--protocol", "paper", "--vary", "gamma=1e-9,1e-10", "--out", d, "--quiet")
        self.check("[12] plot --where gamma=1e-9 of gamma=1e-9,1e-10",
                   bk("plot", d, "--where", "gamma=1e-9"), {0})
        self.check("[12] plot of --vary gamma=1e-9,1e-10", bk("plot", d), {0})
        bad = os.fsdecode(os.fsencode(str(self.scratch())) + b"/bad\xff")
        for cmd in (["sweep", "--phi", "1", "--out", bad], ["collect", bad], ["plot", bad]):
            p = subprocess.run([BKFLOW, *cmd], capture_output=True, text=True,
                               errors="replace")
            self.check(f"[12] {cmd[0]} into a non-UTF-8 name", p, {2})
        for case, env, code in (("SIGNAC_FLOW_ENVIRONMENT=garbage",
                                 {"SIGNAC_FLOW_ENVIRONMENT": "garbage"}, 0),
                                ("MPLBACKEND=garbage", {"MPLBACKEND": "garbage"}, 0),
                                ("TQDM_MININTERVAL=abc", {"TQDM_MININTERVAL": "abc"}, 2),
                                ("TQDM_NCOLS=x", {"TQDM_NCOLS": "x"}, 2)):
            out = self.scratch() / "s"
            p = bk("sweep", "--phi", "1", "--seeds", "1", "--t-end", "50", "--scene",
                   "friction", "--out", out, "--quiet", env={**os.environ, **env})
            self.check(f"[12] sweep with {case}", p, {code})
        out = self.scratch() / "r"
        p = subprocess.run(f"'{BKFLOW}' run --phi 10 {' '.join(SHORT)} --out '{out}' 2>&-",
                           shell=True, capture_output=True, text=True)
        self.check("[12] run with stderr closed", p, {0})
        gone = self.scratch() / "gone"
        for case, out, code in (("an absolute --out", self.scratch() / "r", 0),
                                ("a relative --out", "r", 4)):
            gone.mkdir(exist_ok=True)
            p = subprocess.run(f"cd '{gone}' && rmdir '{gone}' && '{BKFLOW}' run --phi 10 "
                               f"{' '.join(SHORT)} --out '{out}'", shell=True,
                               capture_output=True, text=True)
            self.check(f"[12] run in a deleted directory with {case}", p, {code})

    def signals(self):
        for sig in (signal.SIGHUP, signal.SIGTERM, signal.SIGINT):
            d = self.scratch()
            p = subprocess.Popen([BKFLOW, "run", "--phi", "1000", "--n", "900", "--t-end",
                                  "20000", "--out", str(d / "r"), "--quiet"],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            deadline = time.time() + 60
            while not (d / "r" / "extrema.npy").exists() and time.time() < deadline:
                time.sleep(0.1)
            time.sleep(1.0)
            t0 = time.time()
            p.send_signal(sig)
            out, err = p.communicate(timeout=60)
            waited = time.time() - t0
            name = signal.Signals(sig).name
            self.check(f"[13] {name} to a run after MPI loaded (exited after {waited:.2f} s)",
                       subprocess.CompletedProcess(p.args, p.returncode, out, err), {130},
                       [d / "r"])
            if waited > 1.0:
                self.results[-1].verdict = f"took {waited:.2f} s"

    def docs(self):
        import re

        texts = [(ROOT / f).read_text() for f in ("README.md", "docs/cluster.md",
                                                   "src/bkflow/cluster.py")]
        cmds = sorted({m.strip() for t in texts
                       for m in re.findall(r"python -m bkflow\.cluster run([^`\n#]*)", t)})
        for args in cmds:
            d = self.scratch() / "c"
            bk("sweep", "--phi", "1,3", "--seeds", "1", "--t-end", "50", "--scene", "friction",
               "--protocol", "paper", "--out", d, "--init")
            p = subprocess.run([sys.executable, "-m", "bkflow.cluster", "run", *args.split()],
                               cwd=d, capture_output=True, text=True, timeout=600)
            p = subprocess.CompletedProcess(p.args, p.returncode, p.stdout, "")  # flow's bars
            self.check(f"[14] the documented `python -m bkflow.cluster run {args}`", p, {0})

    def cluster(self):
        for args in (["status", "-j", "nosuchjob"], ["run", "-j", "deadbeef"],
                     ["exec", "simulate", "nosuchjob"], ["submit", "--bundle", "-1",
                                                         "--pretend"]):
            d = self.scratch() / "s"
            shutil.copytree(self.sweep, d)
            p = subprocess.run([sys.executable, "-m", "bkflow.cluster", *args], cwd=d,
                               capture_output=True, text=True, timeout=120,
                               env={**os.environ,
                                    "SIGNAC_FLOW_ENVIRONMENT": "StandardEnvironment"})
            self.check(f"[14] python -m bkflow.cluster {' '.join(args)}", p, {2})

    # ------------------------------------------------------------------ the third round
    def _victim(self) -> tuple[Path, str]:
        """A file outside every directory a case gives bkflow, and its digest."""
        v = self.scratch() / "victim.txt"
        v.write_text("the user's file\n")
        return v, hashlib.sha256(v.read_bytes()).hexdigest()

    def _untouched(self, victim: Path, sha: str) -> None:
        if not victim.exists() or hashlib.sha256(victim.read_bytes()).hexdigest() != sha:
            self.results[-1].verdict = "touched a file outside the directory"

    def _sweep_copy(self, full: bool = False) -> Path:
        d = self.scratch() / "s"
        shutil.copytree(self.sweep, d, symlinks=True)
        return d

    def third_round(self):
        """Issue "Faults, third round": each class [T1]-[T12], several instances."""
        # [T1] nothing outside the directory is deleted, replaced or written through
        for how in ("absolute path", "../ path", "symlink in figures/"):
            d = self._sweep_copy()
            victim, sha = self._victim()
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
            self.check(f"[T1] collect with figures.json naming the user's file ({how})",
                       bk("collect", d), {0, 2})
            self._untouched(victim, sha)
        for planted in ("figures -> outside", "workspace -> outside", "a job -> outside"):
            d = self._sweep_copy()
            outside = self.scratch() / "outside"
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
            self.check(f"[T1] {cmd[0]} of a sweep whose {planted}", bk(*cmd), {0, 2})
            if digest(outside) != before:
                self.results[-1].verdict = "changed a file outside the directory"
            self._untouched(victim, sha)
        d = self.scratch() / "run"
        shutil.copytree(self.base, d)
        victim, sha = self._victim()
        (d / "extrema.npy").unlink()   # a record every scene's run writes again
        (d / "extrema.npy").symlink_to(victim)
        self.check("[T1] run --overwrite of a run whose extrema.npy links out",
                   bk("run", "--phi", "10", "--t-end", "200", "--overwrite", "--quiet",
                      "--out", d), {0, 2})
        self._untouched(victim, sha)
        # [T2] the job script as Slurm reads it: one option per #SBATCH line
        d = self.scratch() / "g"
        bk("sweep", "--phi", "1,3", "--seeds", "1", "--t-end", "50", "--scene", "friction",
           "--out", d, "--init")
        fake = self.scratch()   # a scheduler with an empty queue: what submit asks first
        (fake / "squeue").write_text("#!/bin/sh\nexit 0\n")
        (fake / "squeue").chmod(0o755)
        env = {**os.environ, "SIGNAC_FLOW_ENVIRONMENT": "DefaultSlurmEnvironment",
               "PATH": f"{fake}{os.pathsep}{os.environ['PATH']}"}
        for extra in ([], ["--bundle", "2", "--parallel"]):
            p = subprocess.run([sys.executable, "-m", "bkflow.cluster", "submit", "--pretend",
                                *extra], cwd=d, capture_output=True, text=True, timeout=120,
                               env=env)
            # sbatch reads a directive up to a second "#": an option after it is lost
            lines = [ln for ln in p.stdout.splitlines() if ln.startswith("#SBATCH")]
            bad = [ln for ln in lines if "#" in ln[len("#SBATCH"):]
                   or len(ln[len("#SBATCH"):].split()) > 2]
            options = {ln[len("#SBATCH"):].split()[0].split("=")[0] for ln in lines}
            self.check(f"[T2] submit --pretend {' '.join(extra)}: one option per #SBATCH",
                       subprocess.CompletedProcess(p.args, p.returncode, p.stdout, ""), {0})
            scripts = p.stdout.split("#!/bin/bash")
            if scripts[0].strip():   # text in front of the #!: sbatch refuses the script
                self.results[-1].verdict = f"text before #!: {scripts[0].strip()[:60]}"
            elif bad or not {"--nodes", "--cpus-per-task"} <= options:
                self.results[-1].verdict = f"directives lost: {bad[:1] or sorted(options)}"
        # [T3] a plot under way and a collect that changes the tables exclude each other
        d = self._sweep_copy()
        plot = subprocess.Popen([BKFLOW, "plot", str(d)], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        time.sleep(1.0)
        coll = bk("collect", d, "--analysis", "slip_threshold=0.02")
        plot.communicate(timeout=600)
        self.check("[T3] collect --analysis while a plot draws", coll, {0, 3})
        rec = d / "figures" / "figures.json"
        if rec.exists():
            r = json.loads(rec.read_text())
            from bkflow.store.tables import tables_digest

            if r.get("complete") and r.get("tables_sha256") == tables_digest(d) and not all(
                    (d / "figures" / f).is_file() for f in r.get("files", [])):
                self.results[-1].verdict = "figures.json current, its files missing"
        # [T4]-[T6] a set changed in part, cut derived files, damage the command repairs
        d = self._sweep_copy()
        (d / "runs.csv").write_text((d / "runs.csv").read_text().rsplit("\n", 2)[0] + "\n")
        self.check("[T4] plot of a sweep whose runs.csv is from another collect",
                   bk("plot", d), {2})
        self.check("[T4] the collect it names repairs it", bk("collect", d), {0})
        for damage in ("clusters.csv cut", "events.parquet cut, events.csv empty",
                       "summary.json of another analysis"):
            d = self._sweep_copy()
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
            self.check(f"[T5/T6] collect of a sweep with a job's {damage}", bk("collect", d),
                       {0})
        # [T7] a companion that is not the run's
        pair = self.scratch()
        bk("run", "--phi", "10", "--size", "12x3", "--t-end", "600", "--scene", "friction",
           "--quiet", "--out", pair / "run")
        bk("run", "--phi", "10", "--size", "12x3", "--t-end", "600", "--scene", "friction",
           "--protocol", "paper", "--start", "random", "--quiet", "--out", pair / "other")
        for stand_in in ("a run from the main run's start", "the main run itself",
                         "a symbolic link to another run"):
            d = self.scratch() / "run"
            shutil.copytree(pair / "run", d)
            shutil.rmtree(d / "companion")
            if stand_in.startswith("a symbolic"):
                (d / "companion").symlink_to(pair / "other")
            else:
                src = pair / "other" if stand_in.startswith("a run") else pair / "run"
                shutil.copytree(src, d / "companion", ignore=shutil.ignore_patterns("companion"))
            self.check(f"[T7] analyze with companion/ replaced by {stand_in}",
                       bk("analyze", d), {2})
        # [T8] the API's errors are the CLI's
        # the sweep's catalogue is made from its runs' own (workspace/JOB/events.parquet)
        d = self._sweep_copy()
        cat = sorted((d / "workspace").iterdir())[0] / "events.parquet"
        cat.write_bytes(cat.read_bytes()[:100])
        code = ("import sys\nfrom bkflow.api import load_sweep\ntry:\n"
                f"    load_sweep({str(d)!r}).events\nexcept Exception as e:\n"
                "    print(type(e).__name__, file=sys.stderr); sys.exit(2)")
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        self.check("[T8] load_sweep().events of a run's cut events.parquet", p, {2})
        if p.stderr.strip() not in ("StaleTablesError", "DamagedRunError"):
            self.results[-1].verdict = f"raised {p.stderr.strip()[:60]}"
        # [T9] --set goes through the option's checks
        for args in (["--set", "companion=partial"], ["--set", "until_steady=true"],
                     ["--set", "target_error=1e-3"], ["--set", "dt_factor=5"]):
            out = self.scratch() / "deck"
            self.check(f"[T9] deck {' '.join(args)}", bk("deck", "--phi", "10", *args,
                                                         "--out", out), {2})
        # [T10] the advice names what was changed
        d = self.scratch() / "deck"
        bk("deck", "--phi", "10", "--t-end", "50", "--out", d)
        text = (d / "in.bk").read_text()
        import re

        (d / "in.bk").write_text(re.sub(r"(?m)^run( +)\d+", r"run\g<1>100", text))
        (d / "extrema.npy").write_bytes(b"")   # lmp -in in.bk has begun its records
        p = bk("analyze", d)
        self.check("[T10] analyze after in.bk was edited", p, {2})
        if "in.bk was edited" not in p.stderr:
            self.results[-1].verdict = "advice not about in.bk"
        d = self._sweep_copy()
        from signac.job import calc_id

        job = sorted((d / "workspace").iterdir())[0]
        point = json.loads((job / "signac_statepoint.json").read_text())
        point["phi"] = -1.0
        (job / "signac_statepoint.json").write_text(json.dumps(point))
        job.rename(job.with_name(calc_id(point)))
        for env in ("StandardEnvironment", "NoSuchEnvironment"):
            p = subprocess.run([sys.executable, "-m", "bkflow.cluster", "status"], cwd=d,
                               capture_output=True, text=True, timeout=120,
                               env={**os.environ, "SIGNAC_FLOW_ENVIRONMENT": env})
            self.check(f"[T10] cluster status of a rehashed state point phi = -1 ({env})", p,
                       {2})
            if "no working scheduler" in p.stderr:
                self.results[-1].verdict = "blamed the scheduler"
        # [T11] printed commands safe to paste
        for name in ("g $(touch PWNED)", "-x", "a'b; touch PWNED"):
            d = self.scratch()
            p = subprocess.run([BKFLOW, "sweep", "--phi", "10", "--seeds", "1",
                                f"--out={name}", "--init"], cwd=d, capture_output=True,
                               text=True, timeout=120)
            self.check(f"[T11] sweep --init into {name!r}: the printed cd, pasted", p, {0})
            if "(cd " in p.stdout:
                cd = p.stdout.split("(cd ", 1)[1].split(" && ", 1)[0]
                sh = subprocess.run(["bash", "-c", f"cd {cd} && pwd -P"], cwd=d,
                                    capture_output=True, text=True)
                if sh.stdout.strip() != str((d / name).resolve()) or list(d.rglob("PWNED")):
                    self.results[-1].verdict = f"pasted, it did something else: {cd}"
        # [T12] a planted mark replaces nothing
        for mark in ("", '{"bkflow": "0", "began": 0}'):
            d = self.scratch() / "mine"
            d.mkdir()
            (d / "stress.csv").write_text("my measurements\n")
            os.utime(d / "stress.csv", (time.time() - 3600,) * 2)
            (d / ".bkflow-run").write_text(mark)
            kind = "empty" if not mark else "older stress.csv"
            self.check(f"[T12] run into a directory with a planted mark ({kind})",
                       bk("run", "--phi", "10", *SHORT, "--out", d), {2})
            if (d / "stress.csv").read_text() != "my measurements\n":
                self.results[-1].verdict = "replaced the user's stress.csv"

    def fresh_attack(self):
        """What a fresh attack (a helper who had not read the change) found, each a case."""
        d = self._sweep_copy()
        fig = d / "figures"
        bk("plot", d)
        rec = json.loads((fig / "figures.json").read_text())
        rec["files"].append("/tmp/x")
        (fig / "figures.json").write_text(json.dumps(rec))
        self.check("[F] plot past a figures.json naming an absolute path", bk("plot", d), {0})
        d = self._sweep_copy()
        (d / ".signac" / "config").unlink()
        self.check("[F] collect of a sweep without .signac/config", bk("collect", d), {2})
        for name in ("summary.json", "meta.json"):
            d = self._sweep_copy()
            job = sorted((d / "workspace").iterdir())[0]
            (job / name).unlink()
            os.mkfifo(job / name)
            try:
                p = bk("collect", d, timeout=60)
            except subprocess.TimeoutExpired:
                self.results.append(Result(f"[F] collect with a FIFO as a run's {name}", None,
                                           "", "hung"))
                continue
            self.check(f"[F] collect with a FIFO as a run's {name}", p, {0, 2})
        m = self.scratch() / "m"
        m.mkdir()
        (m / "stress.csv").write_text("MY DATA\n")
        shutil.copy(self.base / ".bkflow-run", m / ".bkflow-run")
        self.check("[F] run into a folder with a copied .bkflow-run mark",
                   bk("run", "--phi", "10", *SHORT, "--out", m), {2})
        if (m / "stress.csv").read_text() != "MY DATA\n":
            self.results[-1].verdict = "replaced the user's stress.csv"
        out = self.scratch() / "v"
        self.check("[F] sweep --vary until_steady=true,false (steady protocol)",
                   bk("sweep", "--phi", "1", "--vary", "until_steady=true,false", "--out", out),
                   {2})
        self.check("[F] run --protocol paper --companion partial --target-error 1e-3",
                   bk("run", "--phi", "1", "--size", "12x3", "--protocol", "paper",
                      "--companion", "partial", "--target-error", "1e-3", "--t-end", "300",
                      "--scene", "friction", "--quiet", "--out", self.scratch() / "r"), {0})
        self.check("[F] run --out /proc/x", bk("run", "--phi", "10", *SHORT, "--out",
                                              "/proc/x"), {4})

    def run_all(self):
        for part in (self.arguments, self.paths, self.directories, self.damaged, self.writers,
                     self.disk_full, self.interrupts, self.pipes, self.hangs, self.users_files,
                     self.misread, self.options, self.workspace, self.tracebacks, self.signals,
                     self.docs, self.cluster, self.third_round, self.fresh_attack,
                     self.fourth_round):
            part()
        return self.results

    def fourth_round(self):
        """Classes [F1]-[F18] (benchmarks/checks/faults/records.py)."""
        from benchmarks.checks.faults.records import fourth_round

        fourth_round(self)


def _whole_figure(path: Path) -> bool:
    """A PNG that Pillow reads to its end, or a PDF that ends as a PDF does."""
    data = path.read_bytes()
    if path.suffix == ".pdf":
        return data.startswith(b"%PDF") and b"%%EOF" in data[-64:]
    from io import BytesIO

    from PIL import Image

    try:
        Image.open(BytesIO(data)).load()
        return True
    except Exception:
        return False


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--keep", default=None, help="scratch directory to keep (default: a temp)")
    ap.add_argument("--only", default=None, help="run only this part (e.g. third_round)")
    a = ap.parse_args(argv)
    # started in the background (`cmd &` in a script), this process has SIGINT ignored, and so
    # would every bkflow it starts (an ignored signal stays ignored across exec): the Ctrl-C
    # cases need it as a terminal would deliver it
    signal.signal(signal.SIGINT, signal.default_int_handler)
    root = Path(a.keep or tempfile.mkdtemp(prefix="bkflow-faults-"))
    root.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    fuzz = Fuzz(root)
    results = fuzz.run_all() if a.only is None else (getattr(fuzz, a.only)(), fuzz.results)[1]
    print("| # | case | exit | last line of stderr (or first of stdout) | verdict |")
    print("|---|---|---|---|---|")
    for k, r in enumerate(results, 1):
        print(f"| {k} | {r.case} | {r.code} | {r.first.replace('|', '/')} | {r.verdict} |")
    clean = sum(r.verdict == "CLEAN" for r in results)
    skipped = sum(r.verdict == "SKIPPED" for r in results)
    print(f"\n{clean} CLEAN, {skipped} SKIPPED, {len(results) - clean - skipped} not clean, "
          f"of {len(results)} cases in {time.time() - t0:.0f} s")
    if a.only is None:   # the whole fuzz is the record RESULTS.md's table is made from
        RECORD.parent.mkdir(parents=True, exist_ok=True)
        scratch = str(root)
        RECORD.write_text(json.dumps({
            "date": time.strftime("%Y-%m-%d"), "seconds": round(time.time() - t0),
            "cases": [{"case": r.case, "exit": r.code,
                       "line": r.first.replace(scratch, "SCRATCH"), "verdict": r.verdict}
                      for r in results]}, indent=1) + "\n")
        print(f"wrote {RECORD}")
    if not a.keep:
        shutil.rmtree(root, ignore_errors=True)
    return 0 if clean + skipped == len(results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
