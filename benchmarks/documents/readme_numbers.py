"""The README's numbers, measured: the main command's wall time, disk use and printed table, the
quick start's output and size, and the test suite's size and time, written to
benchmarks/records/readme_numbers.json and from there into README.md's generated blocks.

    python -m benchmarks.documents.readme_numbers [--sweep] [--run] [--tests] [--sizes]
        [--write-readme]

--sweep         run ``bkflow sweep --phi 1e-1:1e3`` into a fresh directory (about 10 minutes on
                2 cores), timing it and measuring what it wrote
--run           run the quick start's ``bkflow run`` into a fresh directory
--tests         run ``pytest`` once, timing it, and count the tests and the fast subset
--write-readme  (re)write README.md's generated blocks from the record (and the synopses
                from the program's own parser)

Without options it changes nothing and checks: exit 1 when README.md differs from what
the record and the parser give. ``tests/test_readme.py`` makes the same check, so the README
cannot drift from the measurements, and runs the quick start itself to compare its output.
"""

from __future__ import annotations

import os
import platform
import re
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.harness import RECORDS, ROOT, parser, read_json, tool, write_json

README = ROOT / "README.md"
RECORD = RECORDS / "readme_numbers.json"
SWEEP = "bkflow sweep --phi 1e-1:1e3 --out runs/sweep"
RUN = "bkflow run --phi 10 --n 100 --seed 1 --out runs/phi10"


def disk_bytes(path: Path) -> int:
    """Bytes a directory takes on disk (``du``'s allocated blocks, as a user sees it)."""
    out = subprocess.run(["du", "-s", "--block-size=1", str(path)], capture_output=True,
                         text=True, check=True).stdout
    return int(out.split()[0])


def human(n: float) -> str:
    """1.8 GB, 12 MB: two significant digits, decimal units (as ``du -h --si``)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 999.5 or unit == "TB":
            return f"{n:.2g} {unit}" if n < 100 else f"{n:.0f} {unit}"
        n /= 1000
    raise AssertionError


def duration(s: float) -> str:
    m, sec = divmod(round(s), 60)
    return f"{m} min {sec} s" if m else f"{sec} s"


def _run(cmd: str, cwd: Path) -> tuple[str, float]:
    args = shlex.split(cmd)
    t0 = time.perf_counter()
    p = subprocess.run([tool(args[0]), *args[1:]], cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"{cmd} failed (exit {p.returncode}): {p.stderr.strip()[-500:]}")
    return p.stdout, wall


def _scratch() -> Path:
    """Where the measured commands run: runs/ of the checkout (ignored by git; the same file
    system as the project, as a user's run would be)."""
    d = ROOT / "runs"
    d.mkdir(exist_ok=True)
    return d


#: the README's figure: fig2a of `bkflow plot runs/sweep` after the README's own sweep
HERO = ROOT / "docs" / "images" / "readme_fig2a.png"


def measure_sweep(command: str = SWEEP, hero: Path | None = None) -> dict:
    """The sweep ``command`` timed in a scratch directory, its bytes and its output; with
    ``hero``, then the README's `bkflow plot runs/sweep` (not timed), its fig2a copied there."""
    import shutil

    with tempfile.TemporaryDirectory(prefix="readme-numbers-", dir=_scratch()) as d:
        out, wall = _run(command, Path(d))
        size = disk_bytes(Path(d) / "runs" / "sweep")
        by_size = where_it_goes(Path(d) / "runs" / "sweep")
        if hero is not None:
            _run("bkflow plot runs/sweep", Path(d))
            shutil.copyfile(Path(d) / "runs" / "sweep" / "figures" / "fig2a_friction.png", hero)
    runs = int(re.search(r"= (\d+) runs into", out).group(1))
    jobs = int(re.search(r", (\d+) at a time", out).group(1))
    return {"command": command, "wall_s": wall, "bytes": size, "runs": runs, "jobs": jobs,
            "cores": os.cpu_count(), "output": out.rstrip("\n"), "by_size": by_size}


def where_it_goes(sweep: Path) -> dict:
    """Per size of a finished sweep: its runs, the seconds they took (each run's and its
    companion's LAMMPS time, meta.json's wall_time_s, summed), the runs that went to their cap
    and the seconds those took (runs.csv)."""
    import pandas as pd

    runs = pd.read_csv(sweep / "runs.csv")
    capped = runs.t_run >= runs.t_end * (1 - 1e-9)
    return {str(n): {"runs": int(len(g)), "run_s": float(g.wall_time_s.sum()),
                     "capped": int(capped[g.index].sum()),
                     "capped_s": float(g.wall_time_s[capped[g.index]].sum())}
            for n, g in runs.groupby("N")}


#: the steady protocol at the paper's three sizes in one command (REPRODUCTION): the main
#: command's grid, and where its time goes size by size
SIZES = ("100,400,900",)


def measure_sizes() -> dict:
    """The main command's grid under the steady protocol at N = SIZES, recording only the
    stress's and the phases' records (--scene friction: the protocol's time is the
    simulation's): {N: measure_sweep}."""
    return {n: measure_sweep(f"{SWEEP} --sizes {n} --scene friction") for n in SIZES}


def _commit() -> str:
    p = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                       text=True)
    return p.stdout.strip() or "unknown"


#: the event catalogue's columns the README shows, with their headers
CATALOGUE_SHOWN = (("t_max", "t_max", ".1f"), ("duration", "duration", ".2f"),
                   ("drop", "drop", ".4f"), ("n_slipped", "slipped", "d"),
                   ("breaks", "breaks", "d"), ("potency", "potency", ".2f"),
                   ("cluster_nx", "n_x", "d"), ("cluster_ny", "n_y", "d"),
                   ("nucleation_x", "nucl. x", ".0f"), ("nucleation_y", "nucl. y", ".0f"),
                   ("front_speed", "front speed", ".2f"),
                   ("drive_released", "drive released", ".3f"),
                   ("bond_released", "bonds released", ".3f"),
                   ("dissipated_breaks", "breaks dissipated", ".3f"),
                   ("dissipated_damping", "damping dissipated", ".3f"),
                   ("energy_closure", "closure", ".1e"))


def catalogue_table(events, rows: int = 6) -> str:
    """The first ``rows`` slips after the transient of an event catalogue (a DataFrame), as a
    markdown table of ``CATALOGUE_SHOWN``."""
    late = events[events["late"].astype(bool)].head(rows)
    shown = [(c, h, f) for c, h, f in CATALOGUE_SHOWN if c in late.columns]  # the scene's
    head = "| " + " | ".join(h for _, h, _ in shown) + " |"
    lines = [head, "|" + "---|" * len(shown)]
    for _, r in late.iterrows():
        cells = ["n/a" if r[c] is None or r[c] != r[c] else format(
            int(r[c]) if f == "d" else float(r[c]), f) for c, _, f in shown]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def measure_run() -> dict:
    import pandas as pd

    with tempfile.TemporaryDirectory(prefix="readme-numbers-", dir=_scratch()) as d:
        out, wall = _run(RUN, Path(d))
        size = disk_bytes(Path(d) / "runs" / "phi10")
        events = pd.read_parquet(Path(d) / "runs" / "phi10" / "events.parquet")
    return {"command": RUN, "wall_s": wall, "bytes": size, "output": out.rstrip("\n"),
            "catalogue": catalogue_table(events), "slips": int(len(events))}


def measure_tests() -> dict:
    """The suite, run once as the README says (``pytest``): its count, wall time and outcome,
    and the count of ``-m "not slow"`` with its time read from the same run, the sum of those
    tests' own times (setup, call and teardown, from pytest's JUnit XML report): one run of
    the suite instead of two, on a machine where a run takes a quarter of an hour."""
    import tempfile
    import xml.etree.ElementTree as ET

    def ids(*marks: str) -> list[str]:
        p = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q",
                            "-p", "no:cacheprovider", *marks], cwd=ROOT, capture_output=True,
                           text=True)
        return [ln.strip() for ln in p.stdout.splitlines() if "::" in ln]

    # the one test that checks README against this record cannot pass before it is written
    # (and one that compares the record's counts with today's suite, when there is one)
    this = ["--deselect", "tests/test_readme.py::test_the_readmes_measured_numbers_are_the_record",
            "--deselect", "tests/test_readme.py::test_the_records_test_counts_are_todays"]
    with tempfile.TemporaryDirectory() as tmp:
        xml = Path(tmp) / "suite.xml"
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                            f"--junitxml={xml}", *this], cwd=ROOT, capture_output=True,
                           text=True)
        wall = time.perf_counter() - t0
        times = {}
        for case in ET.parse(xml).getroot().iter("testcase"):
            module = case.get("classname", "").replace(".", "/")
            times[f"{module}.py::{case.get('name')}"] = float(case.get("time", 0.0))
    every, fast = ids(), ids("-m", "not slow")
    fast_s = sum(times.get(i, 0.0) for i in fast)
    return {"all": len(every), "fast": len(fast), "wall_s": wall, "fast_wall_s": fast_s,
            "fast_timed": "within the whole run (its tests' own times)",
            "passed": p.returncode == 0, "cores": os.cpu_count(),
            "summary": p.stdout.strip().splitlines()[-1] if p.stdout.strip() else p.stderr[-300:],
            "failed": [ln for ln in p.stdout.splitlines() if ln.startswith(("FAILED", "ERROR"))],
            "slowest": sorted(((round(v, 1), k) for k, v in times.items()), reverse=True)[:15]}


# --------------------------------------------------------------------------- the README
def printed_wall(output: str) -> int | None:
    """The wall time a sweep printed (``N run(s) done in H:MM:SS``), in seconds; None if
    ``output`` has none."""
    m = re.search(r"run\(s\) done in (?:(\d+) days?, )?(\d+):(\d\d):(\d\d)", output)
    if m is None:
        return None
    d, h, mi, sec = (int(g or 0) for g in m.groups())
    return ((d * 24 + h) * 60 + mi) * 60 + sec


def blocks(record: dict) -> dict[str, str]:
    """{generated block name: its text} from the record.

    The main command's wall time is the one its printed output (the block ``sweep-output``)
    gives, so that the README states one time for it: the command's own wall time
    (``wall_s``, measured around the process) is a second or so longer, and a reader shown
    both would see two."""
    out = {}
    s = record.get("sweep")
    if s:
        wall = printed_wall(s["output"])
        wall = s["wall_s"] if wall is None else wall
        out["sweep-cost"] = (
            f"The sweep runs 13 phi from 0.1 to 1000 x 3 seeds on the paper's 20x5 lattice, each "
            f"run beside\na companion from the other side of the steady state until both are "
            "steady, agree within the\nerror target and their mean is within it, or to the cap "
            "(the stiff layers, which switch\nbetween states more slowly than a run averages "
            f"over): "
            f"{s['runs']} pairs of runs in\n{duration(wall)} on a {s['cores']}-core "
            f"machine ({s['jobs']} at a time), {human(s['bytes'])} on disk\n"
            "(`python -m benchmarks.documents.readme_numbers` measured it; the default scene "
            "keeps what\nthe table and the figures show, reduced in the run; `--scene full` "
            "keeps everything).")
        out["sweep-output"] = "```\n" + s["output"] + "\n```"
    r = record.get("run")
    if r and "catalogue" in r:
        out["catalogue"] = r["catalogue"]
    t = record.get("tests")
    if t:
        out["tests"] = (f"Measured on a {t['cores']}-core machine: {t['all']} tests in "
                        f"{duration(t['wall_s'])}; `-m \"not slow\"` runs {t['fast']} of them "
                        f"in about {duration(t['fast_wall_s'])} (their own times in that run).")
    return out


def _synopses() -> dict[str, str]:
    from bkflow.cli.parser import subcommands, synopsis

    return {cmd: synopsis(cmd) for cmd in subcommands()}


def render(text: str, record: dict, synopses: dict[str, str] | None = None) -> str:
    """``text`` (README.md) with its generated blocks, sizes and synopses filled in."""
    for name, body in blocks(record).items():
        text = re.sub(rf"(<!-- generated: {name} -->\n).*?\n?(<!-- end -->)",
                      lambda m, body=body: m.group(1) + body + "\n" + m.group(2), text,
                      flags=re.S)
    r = record.get("run")
    if r:
        text = re.sub(r"(<!-- size: runs/phi10 -->).*?(<!-- end -->)",
                      lambda m: m.group(1) + human(r["bytes"]) + m.group(2), text)
        text = re.sub(rf"(<!-- output: {re.escape(RUN)} -->\n```\n).*?(```)",
                      lambda m: m.group(1) + r["output"] + "\n" + m.group(2), text, flags=re.S)
    return render_synopses(text, synopses or {})


def render_synopses(text: str, synopses: dict[str, str]) -> str:
    """``text`` (README.md or a page of docs/) with every command's synopsis block filled in."""
    for cmd, syn in synopses.items():
        text = re.sub(rf"(<!-- synopsis: {cmd} -->\n```\n).*?(```)",
                      lambda m, syn=syn: m.group(1) + syn + "\n" + m.group(2), text, flags=re.S)
    return text


def load() -> dict:
    """The README's record (empty where nothing was measured yet)."""
    return read_json(RECORD) or {}


def main(argv=None) -> int:
    p = parser(__doc__)
    p.add_argument("--sweep", action="store_true")
    p.add_argument("--run", action="store_true")
    p.add_argument("--tests", action="store_true")
    p.add_argument("--sizes", action="store_true",
                   help=f"the main command at N = {', '.join(map(str, SIZES))} (REPRODUCTION)")
    p.add_argument("--write-readme", action="store_true",
                   help="write README.md from the record, and every synopsis of docs/")
    a = p.parse_args(argv)
    record = load()
    machine = {"machine": platform.machine(), "python": platform.python_version(),
               "date": time.strftime("%Y-%m-%d")}
    for flag, key, fn in ((a.run, "run", measure_run),
                          (a.sweep, "sweep", lambda: measure_sweep(hero=HERO)),
                          (a.tests, "tests", measure_tests), (a.sizes, "sizes", measure_sizes)):
        if flag:
            print(f"measuring {key} ...", flush=True)
            record[key] = {**fn(), **machine, "commit": _commit()}
            if key == "sweep":   # every measurement of the main command, for RESULTS
                s = record[key]
                record.setdefault("sweep_history", []).append(
                    {k: s[k] for k in ("date", "commit", "wall_s", "bytes", "runs", "jobs")})
            write_json(RECORD, record)
            print(f"  {key}: done", flush=True)
    synopses = _synopses()
    text = README.read_text()
    new = render(text, record, synopses)
    if a.write_readme:
        if new != text:
            README.write_text(new)
            print(f"rewrote {README}")
        for page in sorted((ROOT / "docs").glob("*.md")):   # their synopses
            old = page.read_text()
            if render_synopses(old, synopses) != old:
                page.write_text(render_synopses(old, synopses))
                print(f"rewrote {page}")
        return 0
    if new != text:
        print("README.md differs from the record: run with --write-readme", file=sys.stderr)
        return 1
    print("README.md agrees with the record")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
