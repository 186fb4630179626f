"""The cases of bad inputs: arguments no command accepts, paths of every character, output
directories that are not bkflow's, damaged and cut files, a hand-edited sweep ([11]).
"""

from __future__ import annotations

import json
import shutil
import subprocess

from benchmarks.checks.faults.fuzz import SHORT, Fuzz, bk, complete, digest, row_cut
from benchmarks.harness import tool


def arguments(fuzz: Fuzz) -> None:
    """Every bad argument of bkflow run, deck and sweep is refused (exit 2) before a
    directory is made."""
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
        out = fuzz.scratch() / "out"
        fuzz.check(f"run: {case}", bk("run", *args, "--out", out), {2}, [out])
        if out.exists():
            fuzz.results[-1].verdict = "created the output directory"
    out = fuzz.scratch() / "o"
    fuzz.check("deck: --until-steady", bk("deck", "--phi", "1", "--until-steady",
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
        out = fuzz.scratch() / "s"
        fuzz.check(f"sweep: {case}", bk("sweep", *args, "--out", out), {2})
        if out.exists():
            fuzz.results[-1].verdict = "created the sweep directory"


def paths(fuzz: Fuzz) -> None:
    """A working directory and --out with characters a shell or a file format may choke on."""
    for name in ("with space", "hash#mark", "dollar$HOME", "quote'single", 'quote"double',
                 "ünïcødé ß"):
        d = fuzz.scratch() / name
        d.mkdir()
        p = bk("run", "--phi", "10", *SHORT, "--out", "r", cwd=d)
        ok = p.returncode == 0 and complete(d / "r")
        fuzz.check(f"path: cwd and --out with {name}", p, {0})
        if not ok:
            fuzz.results[-1].verdict = "run did not finish"


def directories(fuzz: Fuzz) -> None:
    """Output directories that are files, too long, foreign, another command's or read-only."""
    d = fuzz.scratch()
    (d / "file").write_text("x")
    fuzz.check("out is an existing file", bk("run", "--phi", "10", *SHORT, "--out",
                                             d / "file"), {2, 4})
    fuzz.check("out below a file", bk("run", "--phi", "10", *SHORT, "--out",
                                      d / "file" / "r"), {4})
    fuzz.check("name too long", bk("run", "--phi", "10", *SHORT, "--out", d / ("n" * 300)),
               {4})
    f = d / "foreign"
    f.mkdir()
    (f / "notes.txt").write_text("mine")
    fuzz.check("out holds foreign files", bk("run", "--phi", "10", *SHORT, "--out", f), {2})
    assert (f / "notes.txt").read_text() == "mine"
    deck = d / "deck"
    bk("deck", "--phi", "10", "--out", deck)
    fuzz.check("run into a deck directory", bk("run", "--phi", "10", *SHORT, "--out", deck),
               {2})
    lmp = d / "standalone"
    bk("deck", "--phi", "10", "--t-end", "50", "--scene", "friction", "--out", lmp)
    subprocess.run([tool("lmp"), "-in", "in.bk", "-screen",
                    "none", "-var", "comm_cutoff", "1.0"], cwd=lmp, check=True)
    snap = digest(lmp)
    fuzz.check("run into a finished lmp run", bk("run", "--phi", "10", *SHORT, "--out", lmp),
               {2})
    if digest(lmp) != snap:
        fuzz.results[-1].verdict = "changed the lmp run"
    fuzz.check("run into a finished run", bk("run", "--phi", "10", "--t-end", "200",
                                             "--out", fuzz.base), {2})
    fuzz.check("deck into a finished run", bk("deck", "--phi", "10", "--out", fuzz.base),
               {2})
    ro = d / "ro"
    if fuzz.tmpfs(ro, "ro,size=1m"):
        try:
            fuzz.check("read-only file system", bk("run", "--phi", "10", *SHORT, "--out",
                                                   ro / "r"), {4})
        finally:
            subprocess.run(["umount", str(ro)])
    else:
        fuzz.skip("read-only file system", "mount not allowed here")


def damaged(fuzz: Fuzz) -> None:
    """bkflow analyze, collect and plot of damaged, cut and foreign inputs."""
    def copy():
        d = fuzz.scratch() / "run"
        shutil.copytree(fuzz.base, d)
        return d

    fuzz.check("analyze: no such directory", bk("analyze", fuzz.root / "nowhere"), {2})
    fuzz.check("analyze: empty directory", bk("analyze", fuzz.scratch()), {2})
    d = copy()
    meta = json.loads((d / "meta.json").read_text())
    del meta["params"]
    (d / "meta.json").write_text(json.dumps(meta))
    fuzz.check("analyze: meta.json without params", bk("analyze", d), {2})
    d = copy()
    (d / "meta.json").write_text("{not json")
    fuzz.check("analyze: meta.json not JSON", bk("analyze", d), {2})
    d = fuzz.scratch() / "deck"
    bk("deck", "--phi", "10", "--out", d)
    for name in ("extrema.npy", "blocks.npy"):   # the records lmp -in in.bk would write
        shutil.copy(fuzz.base / name, d / name)
    (d / "params.json").write_text("[1, 2, 3]")
    fuzz.check("analyze: params.json of the wrong shape", bk("analyze", d), {2})
    (d / "params.json").write_text('{"phi": "ten"}')
    fuzz.check("analyze: params.json with a bad value", bk("analyze", d), {2})
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
        fuzz.check(f"analyze: {name} cut at a {cut}", bk("analyze", d), {2})
        if (d / "summary.json").read_bytes() != before:
            fuzz.results[-1].verdict = "rewrote the summary of a damaged run"
    for name in ("extrema.npy", "stress.npy"):
        d = copy()
        (d / name).write_bytes(b"\x00garbage" * 10)
        fuzz.check(f"analyze: {name} replaced by garbage", bk("analyze", d), {2})
    d = copy()
    (d / "summary.json").write_text('{"mu_bar": 0.1')
    fuzz.check("analyze: cut summary.json is redone", bk("analyze", d), {0})
    fuzz.check("collect: not a sweep", bk("collect", fuzz.scratch()), {2})
    fuzz.check("plot: not a sweep", bk("plot", fuzz.scratch()), {2})
    fuzz.check("plot: unknown format", bk("plot", fuzz.sweep, "--out", fuzz.scratch(),
                                          "--format", "jpgx"), {2})
    fuzz.check("plot: --where on no column", bk("plot", fuzz.sweep, "--out", fuzz.scratch(),
                                                "--where", "nosuch=1"), {2})


def workspace(fuzz: Fuzz) -> None:
    """[11] collect and sweep of a sweep whose workspace was edited by hand."""
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
        d = fuzz.scratch() / "s"
        shutil.copytree(fuzz.sweep, d)
        edit(d, sorted((d / "workspace").iterdir())[0])
        for cmd in (["collect", d], ["sweep", "--phi", "1,10", "--seeds", "1", "--t-end",
                                     "100", "--scene", "friction", "--out", d]):
            fuzz.check(f"[11] {cmd[0]} with {case}", bk(*cmd), {2})
