"""Faults, round 4 (issue 41): one test per failure class, each failing before its fix."""

from __future__ import annotations

import re
import shlex
import subprocess
from pathlib import Path

import pytest

from bkflow.cli.assignments import parse_aspect, parse_sizes, parse_where
from bkflow.figures.data import SweepData
from bkflow.model.params import SpecError
from tests.support import tool


def bk(*args, cwd=None, timeout=300):
    return subprocess.run([tool("bkflow"), *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout)


def one_line(proc, needle: str) -> str:
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0]


@pytest.fixture(scope="module")
def three_phi(lammps, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("sweep") / "s"
    p = bk("sweep", "--phi", "1,3,10", "--seeds", "1", "--t-end", "200", "--scene", "friction",
           "--protocol", "paper", "--jobs", "1", "--quiet", "--out", d)
    assert p.returncode == 0, p.stderr
    return d


# ---------------------------------------------------------------- class 18: --where repeated
def test_a_repeated_where_keeps_the_runs_of_any_of_its_values(three_phi, tmp_path):
    """``--where phi=1 --where phi=10`` plots both (it plotted phi = 10 only, silently)."""
    assert parse_where(["phi=1", "phi=10", "phi=1"]) == {"phi": [1.0, 10.0]}
    data = SweepData(three_phi, parse_where(["phi=1", "phi=10"]))
    assert sorted(data.runs.phi) == [1.0, 10.0]
    p = bk("plot", three_phi, "--out", tmp_path / "f", "--where", "phi=1", "--where", "phi=10")
    assert p.returncode == 0, p.stderr
    none = bk("plot", three_phi, "--out", tmp_path / "g", "--where", "phi=2",
              "--where", "phi=5")
    assert none.returncode == 2
    one_line(none, "no finished run has phi = 2.0 or 5.0")


# ---------------------------------------------------------- class 15: circular --aspect advice
@pytest.mark.parametrize("size", ["7x3", "10x3", "8x4"])
def test_the_aspect_advised_for_a_size_is_accepted_for_it(size, tmp_path):
    """The refusal of a size names an --aspect that, passed as printed, takes that size
    (it printed 2.33333 for 7x3 and then refused 2.33333 as "not 2.33333")."""
    with pytest.raises(SpecError) as err:
        parse_sizes(size)
    advised = re.search(r"pass --aspect (\S+) ", str(err.value)).group(1)
    assert parse_sizes(size, parse_aspect(advised)) == [tuple(map(int, size.split("x")))]
    p = bk("sweep", "--phi", "1", "--sizes", size, "--seeds", "1", "--t-end", "100",
           "--init", "--out", tmp_path / "a")
    line = one_line(p, "--aspect")
    cmd = shlex.split(line.split("pass ", 1)[1].split(" or ")[0])
    q = bk("sweep", "--phi", "1", "--sizes", size, "--seeds", "1", "--t-end", "100",
           *cmd, "--init", "--out", tmp_path / "b")
    assert q.returncode == 0, q.stderr
    assert parse_aspect("7/3") == pytest.approx(7 / 3)
    for bad in ("1/0", "a/b", "0/3"):
        with pytest.raises(SpecError):
            parse_aspect(bad)


# ------------------------------------------------------------ class 14: n_blocks unbounded
def test_the_number_of_blocks_is_bounded(three_phi):
    run = next((three_phi / "workspace").iterdir())
    for n in ("101", "1000000", "100000000"):
        p = bk("analyze", run, "--analysis", f"n_blocks={n}")
        assert p.returncode == 2
        one_line(p, "n_blocks must be an integer from 3 to 100")
    assert bk("analyze", run, "--analysis", "n_blocks=100").returncode == 0
