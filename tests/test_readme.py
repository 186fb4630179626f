"""The README is true to the digit: every synopsis (README and docs) is argparse's own, the
quick start's output and size are what the command prints and writes today (but for the wall
time, the throughput and the kernel's name, which depend on the machine; the trajectory does
not), and every measured number in it is the record of benchmarks/documents/readme_numbers.py
(benchmarks/records/readme_numbers.json)."""

from __future__ import annotations

import re
import shlex
import subprocess

import numpy as np
import pytest

from bkflow.cli.parser import subcommands, synopsis
from tests.support import ROOT, tool

README = ROOT / "README.md"
DOCS = sorted((ROOT / "docs").glob("*.md"))
RUNNING = ROOT / "docs" / "running.md"


def _numbers():
    from benchmarks.documents import readme_numbers

    return readme_numbers


def _blocks(kind: str, *pages) -> dict[str, str]:
    """{argument: the fenced block after each ``<!-- kind: argument -->`` marker}."""
    found = {}
    for page in pages or (README,):
        for arg, block in re.findall(rf"<!-- {kind}: (.*?) -->\n```\n(.*?)```",
                                     page.read_text(), flags=re.S):
            found.setdefault(arg, []).append(block.rstrip("\n"))
    return found


def test_every_command_has_its_synopsis_and_each_is_argparses():
    """The README shows the main commands' synopses (sweep, run), the docs every command's;
    each is argparse's own, so ``bkflow CMD --help`` and the page list the same options."""
    readme = _blocks("synopsis")
    assert {"sweep", "run"} <= set(readme)
    every = _blocks("synopsis", README, *DOCS)
    assert set(every) == set(subcommands()), "a synopsis per command: " + ", ".join(
        sorted(set(subcommands()) ^ set(every)))
    for cmd, shown in every.items():
        for block in shown:
            assert block == synopsis(cmd), f"the synopsis of bkflow {cmd} is out of date"


def test_the_readmes_measured_numbers_are_the_record():
    """The sweep's time, size and printed table, the quick start's size and the suite's
    count and time: README.md says what benchmarks/documents/readme_numbers.py measured
    (readme_numbers.json), and the record holds a measurement of each."""
    numbers = _numbers()
    record = numbers.load()
    assert {"sweep", "run", "tests"} <= set(record)
    text = README.read_text()
    assert numbers.render(text, record) == text, \
        "README.md differs from the record: python -m benchmarks.documents.readme_numbers " \
        "--write-readme"
    assert record["sweep"]["command"] in text and record["run"]["command"] in text
    assert record["tests"]["passed"]


def test_the_records_test_counts_are_todays():
    """The suite's counts the README states (the record of readme_numbers.py --tests, all and
    "not slow") are the suite's today: a test added or removed since the measurement fails
    here, until the suite is measured again."""
    import sys

    record = _numbers().load()["tests"]

    def count(*marks: str) -> int:
        p = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q",
                            "-p", "no:cacheprovider", *marks], cwd=ROOT, capture_output=True,
                           text=True)
        return sum("::" in ln for ln in p.stdout.splitlines())

    assert (record["all"], record["fast"]) == (count(), count("-m", "not slow")), \
        "the README's test counts are stale: python -m benchmarks.documents.readme_numbers " \
        "--tests --write-readme"


def test_the_readme_gives_the_main_commands_time_once_and_only_from_the_record():
    """The main command's wall time and disk use are in the README only where
    benchmarks/documents/readme_numbers.py writes them from its record, and its time is one
    number: the cost sentence gives the time the printed output gives (it said 30 s above a run line
    "done in 0:00:29"; once, 8 min 40 s by hand after a re-measurement). No other wall time
    or size is written by hand."""
    numbers = _numbers()
    text = README.read_text()
    cost = re.search(r"<!-- generated: sweep-cost -->\n(.*?)<!-- end -->", text, re.S).group(1)
    shown = re.search(r"<!-- generated: sweep-output -->\n(.*?)<!-- end -->", text,
                      re.S).group(1)
    printed = numbers.printed_wall(shown)
    assert printed is not None, "the sweep's output shows no 'run(s) done in H:MM:SS'"
    times = re.findall(r"\b\d+ min \d+ s\b|\b\d+ min\b|\b\d+(?:\.\d+)? s\b", cost)
    assert times == [numbers.duration(printed)], (times, numbers.duration(printed))
    # every other time of seconds, minutes or hours and every size outside the blocks the
    # generator writes (the scaling model's microseconds per step are no command's time)
    rest = re.sub(r"<!-- (generated|size): .*? -->.*?<!-- end -->", "", text, flags=re.S)
    rest = re.sub(r"<!-- output: .*? -->\n```\n.*?```", "", rest, flags=re.S)
    by_hand = re.findall(r"\b\d+(?:\.\d+)? ?(?:s|min|h|kB|MB|GB|TB)\b|\b\d+:\d\d:\d\d\b", rest)
    assert by_hand == [], f"times or sizes written by hand in README.md: {by_hand}"


#: what depends on the machine in a run's first line: the wall time, the throughput, the kernel
MACHINE = [(re.compile(r" in [0-9.]+ s \([0-9.e+]+ atom-steps/s, (\w+) path, \w+ kernel\)"),
            r" in T s (R atom-steps/s, \1 path, K kernel)")]


def _normal(text: str, out: str) -> str:
    lines = [ln for ln in text.rstrip("\n").splitlines() if ln.strip()]
    lines = [ln.replace(out, "OUT") for ln in lines]
    for pattern, repl in MACHINE:
        lines = [pattern.sub(repl, ln) for ln in lines]
    return "\n".join(lines)


@pytest.mark.slow
def test_the_quick_starts_output_is_todays(lammps, tmp_path):
    (cmd, shown), = [(c, b) for c, b in _blocks("output").items() if c.startswith("bkflow run")]
    args = shlex.split(cmd)
    out = args[args.index("--out") + 1]
    proc = subprocess.run([tool("bkflow"), *args[1:]], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert _normal(proc.stdout, out) == _normal(shown[0], out)
    # the size the README states, to its two digits (file systems round blocks differently)
    numbers = _numbers()
    stated = re.search(r"<!-- size: runs/phi10 -->(.*?)<!-- end -->", README.read_text()).group(1)
    assert numbers.human(numbers.disk_bytes(tmp_path / out)) == stated
    # every file the run wrote is in docs/running.md's table, and every table there names the
    # columns of its file
    table = RUNNING.read_text()
    table = table[table.index("| file | content |"):]
    table = table[:table.index("\n\n")]
    listed = set(re.findall(r"^\| `([^`]+)`(?:, `([^`]+)`)?", table, flags=re.M))
    listed = {n for pair in listed for n in pair if n}
    written = {p.name + ("/" if p.is_dir() else "") for p in (tmp_path / out).iterdir()}
    # a name with STEP in it (restart.STEP.bk) stands for the step's number
    patterns = [re.compile(re.escape(n).replace("STEP", r"\d+") + "$") for n in listed]
    unlisted = {w for w in written if not any(p.match(w) for p in patterns)}
    assert not unlisted, f"files docs/running.md does not list: {unlisted}"
    checked = 0
    for name, columns in re.findall(r"^\| `(\w+\.csv)` \| `([\w,]+)`", table, flags=re.M):
        if (tmp_path / out / name).exists():
            header = (tmp_path / out / name).read_text().splitlines()[0]
            assert header == columns, f"{name}: the table says {columns}, the file has {header}"
            checked += 1
    for name, fields in re.findall(r"^\| `(\w+\.npy)` \| fields `([\w,]+)`", table,
                                   flags=re.M):
        if (tmp_path / out / name).exists():
            names = ",".join(np.load(tmp_path / out / name).dtype.names)
            assert names == fields, f"{name}: the table says {fields}, the file has {names}"
            checked += 1
    assert checked >= 1


def test_the_readme_names_no_option_that_does_not_exist():
    """Every --option the README and the docs write after ``bkflow CMD`` is one of that
    command's."""
    text = "\n".join(p.read_text() for p in (README, *DOCS))
    options = {cmd: {o for a in p._actions for o in a.option_strings}
               for cmd, p in subcommands().items()}
    bad = []
    for line in text.splitlines():
        m = re.search(r"\bbkflow (\w+)\b(.*)", line)
        if not m or m.group(1) not in options:
            continue
        for opt in re.findall(r"(?<![\w-])(--[a-z][a-z-]*)", m.group(2)):
            if opt not in options[m.group(1)]:
                bad.append(f"bkflow {m.group(1)} ... {opt}")
    assert not bad, bad


def test_ci_runs_the_readmes_install_and_test_commands():
    """.ci/run says it performs exactly the README's install and test commands: each of its
    ``pip install`` and ``pytest`` lines is a command of a README block (CI's opt-in
    ``pytest --install-slurm`` included), so what CI checks is what a reader can run."""
    shown, fenced = set(), False
    for ln in README.read_text().splitlines():
        if ln.startswith("```"):
            fenced = not fenced
        elif fenced:
            shown.add(ln.split("#")[0].strip())
    ci = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()
          if ln.strip().startswith(("pip install", "pytest"))]
    assert any(c.startswith("pip install") for c in ci) and any(
        c.startswith("pytest") for c in ci), ci
    assert [c for c in ci if c not in shown] == [], "commands of .ci/run the README does not show"


@pytest.mark.parametrize("flag", ["--until-stationary"])
def test_retired_options_are_gone_from_the_docs(flag):
    for doc in [README, *sorted((ROOT / "docs").glob("*.md"))]:
        assert flag not in doc.read_text(), f"{doc.name} still names {flag}"


def test_the_exit_codes_are_the_clis():
    """docs/running.md's table of exit codes is bkflow.cli.guards.EXIT_CODES, row for row."""
    from bkflow.cli.guards import EXIT_CODES

    text = RUNNING.read_text()
    table = text[text.index("| exit code | meaning |"):]
    rows = table[:table.index("\n\n")].splitlines()[2:]
    assert rows == [f"| {k} | {v.replace('|', chr(92) + '|')} |" for k, v in EXIT_CODES.items()]


@pytest.mark.slow
def test_the_python_example_runs_as_written(lammps, tmp_path):
    """README's Python block, run as written in a fresh directory: it runs, analyses, and
    prints the state and mu_bar."""
    import re
    import subprocess
    import sys

    block = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    p = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    state, mu_bar, breaks = p.stdout.split()
    assert state in ("steady", "drifting", "metastable") and 0.1 < float(mu_bar) < 0.13
    assert int(breaks) > 0


def test_the_readmes_scaling_numbers_are_the_measured_and_the_models():
    """README's "Scaling out": the speed-ups are RESULTS.md's table (throughput.py --scaling),
    the model's constants and stopping points are benchmarks/report/scaling_model.py's on its
    MEASURED"""
    from benchmarks.report import scaling_model as sm

    text = " ".join(README.read_text().split())
    got = re.search(r"two fused ranks run (\d\.\d\d)x one at N = 14400 and (\d\.\d\d)x at 57600 "
                    r"\((\d\.\d\d)x at 230400", text)
    assert got, "README's scaling sentence is gone"
    results = (ROOT / "benchmarks" / "RESULTS.md").read_text()
    section = results[results.index(
        "### Scaling (`python -m benchmarks.measure.throughput --scaling`)"):]
    for n, ratio in zip(("14400", "57600", "230400"), got.groups()):
        row = next(r for r in section.splitlines() if re.match(rf"\| \d+x\d+ \| {n} \|", r))
        assert row.split("|")[7].strip().strip("*") == ratio, (n, row)
    mdl = sm.fit(sm.MEASURED)
    model = re.search(r"t_P = c\(n\) n \(1 \+ ([\d.]+)\) \+ 2 x ([\d.]+) us", text)
    assert model and float(model.group(1)) == round(mdl.kappa, 2)
    assert float(model.group(2)) == round(mdl.lam * 1e6, 1)
    stops = re.search(r"up to all (\d+) cores, and on four nodes up to (\d+) ranks", text)
    assert stops
    assert int(stops.group(1)) == sm.stops(mdl, 10**6, 2000, sm.NODE)
    assert int(stops.group(2)) == sm.stops(mdl, 10**6, 2000, 4 * sm.NODE)


def test_the_readmes_sweeps_are_within_the_cost_limits(monkeypatch, tmp_path, capsys):
    """Every ``bkflow sweep`` the README and the docs show is accepted, without --force, by the
    limits a run or sweep is checked against before it starts (bkflow.lammps.limits), on a machine
    with 32 GB of free disk and 8 GB of memory: the estimates follow the presets' caps, and a
    command a reader copies is not refused (the jobs are only created, --init)."""
    from bkflow.cli.commands import main
    from bkflow.lammps import limits

    monkeypatch.setattr(limits, "_free_disk", lambda path: 32e9)
    monkeypatch.setattr(limits, "_available_memory", lambda: 8e9)
    commands = sorted({ln.split("#")[0].strip() for page in (README, *DOCS)
                       for block in re.findall(r"```\n(.*?)```", page.read_text(), flags=re.S)
                       for ln in block.splitlines() if ln.startswith("bkflow sweep --phi")})
    assert len(commands) >= 2, commands
    for k, cmd in enumerate(commands):
        args = shlex.split(cmd)[1:]
        if "--out" in args:
            i = args.index("--out")
            del args[i:i + 2]
        args += ["--out", str(tmp_path / f"s{k}")] + ([] if "--init" in args else ["--init"])
        code = main(args)
        assert code == 0, f"{cmd}: exit {code}: {capsys.readouterr().err}"

