"""Fuzz bkflow with bad inputs and faults: every one must end CLEAN.

    python benchmarks/faults.py [--keep DIR]

Runs each case as a user would (the ``bkflow`` command, in a scratch directory) and prints a
table: case, exit code, the first line of stderr, verdict. A case is CLEAN when

- the exit code is the one expected (README, "Exit codes"),
- stderr has no traceback and, on failure, exactly one line (a warning line may precede it),
- nothing finished changed: a finished run and a finished sweep made at the start keep every
  byte of every file, and no directory the case wrote into looks finished unless it is.

Some cases need root (a read-only and a full file system are tmpfs mounts); they are listed
as SKIPPED where mounting is not allowed. The classes are those of the faults issue: paths,
cut files, two writers, file-system errors, damaged inputs, absurd requests, wrong advice,
and interrupts.
"""

from __future__ import annotations

import argparse
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

BKFLOW = str(Path(sys.executable).with_name("bkflow"))
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
        p = bk("run", "--phi", "10", "--t-end", "200", "--out", self.base, "--quiet")
        assert p.returncode == 0, p.stderr
        p = bk("sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--scene", "friction",
               "--jobs", "2", "--out", self.sweep, "--quiet")
        assert p.returncode == 0, p.stderr
        self.before = {d: digest(d) for d in (self.base, self.sweep)}
        self.n = 0

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
        ro.mkdir()
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(ro)],
                          capture_output=True).returncode == 0:
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
        small.mkdir()
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=400k", "tmpfs", str(small)],
                          capture_output=True).returncode != 0:
            self.skip("full disk during the run", "mount not allowed here")
            return
        try:
            self.check("disk too small for the estimate: refused before starting",
                       bk("run", "--phi", "10", "--t-end", "2000", "--scene", "friction",
                          "--quiet", "--out", small / "r"), {2}, [small / "r"])
            self.check("--force: the disk fills during the run",
                       bk("run", "--phi", "10", "--t-end", "2000", "--scene", "friction",
                          "--quiet", "--force", "--out", small / "r"), {4}, [small / "r"])
            shutil.rmtree(small / "r", ignore_errors=True)
            # a run that fits, whose analysis does not: fill the disk after the run
            p = bk("run", "--phi", "10", "--t-end", "300", "--scene", "friction", "--quiet",
                   "--no-analyze", "--out", small / "a")
            assert p.returncode == 0, p.stderr
            free = shutil.disk_usage(small).free
            (small / "filler").write_bytes(b"\0" * max(0, free - 2048))
            p = bk("analyze", small / "a")
            self.check("full disk during the analysis", p, {4})
            if any(n.endswith(".tmp") for n in os.listdir(small / "a")):
                self.results[-1].verdict = "left a .tmp file"
            (small / "filler").unlink()
            p = bk("run", "--phi", "10", "--t-end", "300", "--scene", "friction", "--quiet",
                   "--out", small / "a")
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
        (d / "stress.csv").write_text("t,sigma_x\n0,0\n")
        (d / "params.json").write_text("[1, 2, 3]")
        self.check("analyze: params.json of the wrong shape", bk("analyze", d), {2})
        (d / "params.json").write_text('{"phi": "ten"}')
        self.check("analyze: params.json with a bad value", bk("analyze", d), {2})
        for name, cut in (("stress.csv", "line"), ("stress.csv", "middle"),
                          ("slips.lammpstrj", "middle"), ("snapshots.lammpstrj", "middle")):
            d = copy()
            data = (d / name).read_bytes()
            at = data.rfind(b"\n", 0, len(data) // 2) + 1 if cut == "line" else len(data) // 2
            (d / name).write_bytes(data[:at])
            before = (d / "summary.json").read_bytes()
            self.check(f"analyze: {name} cut at a {cut}", bk("analyze", d), {2})
            if (d / "summary.json").read_bytes() != before:
                self.results[-1].verdict = "rewrote the summary of a damaged run"
        d = copy()
        (d / "stress.csv").write_bytes(b"\x00garbage" * 10)
        self.check("analyze: stress.csv replaced by garbage", bk("analyze", d), {2})
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
        first = subprocess.Popen([BKFLOW, "run", "--phi", "1000", "--n", "400", "--t-end",
                                  "1000", "--quiet", "--out", str(d / "r")],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(3)
        second = bk("run", "--phi", "1000", "--n", "400", "--t-end", "1000", "--quiet",
                    "--out", d / "r")
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
                              "--out", str(d / "r"), "--quiet"], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
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

    def run_all(self):
        for part in (self.arguments, self.paths, self.directories, self.damaged, self.writers,
                     self.disk_full, self.interrupts, self.pipes):
            part()
        return self.results


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--keep", default=None, help="scratch directory to keep (default: a temp)")
    a = ap.parse_args(argv)
    root = Path(a.keep or tempfile.mkdtemp(prefix="bkflow-faults-"))
    root.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    results = Fuzz(root).run_all()
    print("| # | case | exit | last line of stderr (or first of stdout) | verdict |")
    print("|---|---|---|---|---|")
    for k, r in enumerate(results, 1):
        print(f"| {k} | {r.case} | {r.code} | {r.first.replace('|', '/')} | {r.verdict} |")
    clean = sum(r.verdict == "CLEAN" for r in results)
    skipped = sum(r.verdict == "SKIPPED" for r in results)
    print(f"\n{clean} CLEAN, {skipped} SKIPPED, {len(results) - clean - skipped} not clean, "
          f"of {len(results)} cases in {time.time() - t0:.0f} s")
    if not a.keep:
        shutil.rmtree(root, ignore_errors=True)
    return 0 if clean + skipped == len(results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
