"""The README is true to the digit: every synopsis is argparse's own, and the quick start's
output is what the command prints today (but for the wall time, the throughput and the
kernel's name, which depend on the machine; the trajectory does not)."""

from __future__ import annotations

import re
import shlex
import subprocess

import pytest

from bkflow.cli import subcommands, synopsis
from tests.support import ROOT, tool

README = ROOT / "README.md"


def _blocks(kind: str) -> dict[str, str]:
    """{argument: the fenced block after each ``<!-- kind: argument -->`` marker}."""
    text = README.read_text()
    found = re.findall(rf"<!-- {kind}: (.*?) -->\n```\n(.*?)```", text, flags=re.S)
    return {arg: block.rstrip("\n") for arg, block in found}


def test_every_command_has_its_synopsis_and_each_is_argparses():
    blocks = _blocks("synopsis")
    assert set(blocks) == set(subcommands()), "a synopsis per command: " + ", ".join(
        sorted(set(subcommands()) ^ set(blocks)))
    for cmd, block in blocks.items():
        assert block == synopsis(cmd), f"README's synopsis of bkflow {cmd} is out of date"


#: what depends on the machine in a run's first line: the wall time, the throughput, the kernel
MACHINE = [(re.compile(r" in [0-9.]+ s \([0-9.e+]+ atom-steps/s, (\w+) path, \w+ kernel\)"),
            r" in T s (R atom-steps/s, \1 path, K kernel)")]


def _normal(text: str, out: str) -> str:
    lines = [ln for ln in text.rstrip("\n").splitlines() if ln.strip()]
    lines = [ln.replace(out, "OUT") for ln in lines]
    for pattern, repl in MACHINE:
        lines = [pattern.sub(repl, ln) for ln in lines]
    return "\n".join(lines)


def test_the_quick_starts_output_is_todays(lammps, tmp_path):
    (cmd, shown), = [(c, b) for c, b in _blocks("output").items() if c.startswith("bkflow run")]
    args = shlex.split(cmd)
    out = args[args.index("--out") + 1]
    proc = subprocess.run([tool("bkflow"), *args[1:]], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert _normal(proc.stdout, out) == _normal(shown, out)


def test_the_readme_names_no_option_that_does_not_exist():
    """Every --option the README writes after ``bkflow CMD`` is one of that command's."""
    text = README.read_text()
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


@pytest.mark.parametrize("flag", ["--until-stationary"])
def test_retired_options_are_gone_from_the_docs(flag):
    for doc in [README, *sorted((ROOT / "docs").glob("*.md"))]:
        assert flag not in doc.read_text(), f"{doc.name} still names {flag}"


def test_the_exit_codes_are_the_clis():
    """README's table of exit codes is bkflow.cli.EXIT_CODES, row for row."""
    from bkflow.cli import EXIT_CODES

    text = README.read_text()
    table = text[text.index("| exit code | meaning |"):]
    rows = table[:table.index("\n\n")].splitlines()[2:]
    assert rows == [f"| {k} | {v.replace('|', chr(92) + '|')} |" for k, v in EXIT_CODES.items()]


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
