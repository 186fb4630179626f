"""``python -m bkflow.slurm``: what it refuses and what it advises (the job scripts' python
quoted, no circular advice, no typo run as nothing)."""

from __future__ import annotations

import os
import shlex
import subprocess
import sys

import pytest

from bkflow.cli.commands import main
from bkflow.sweeps.project import finished, open_project
from tests.support import fake_scheduler


def _slurm(args, cwd, env, prelude=""):
    """``python -m bkflow.slurm ARGS`` in ``cwd``; ``prelude`` runs first in that python."""
    code = f"{prelude}\nfrom bkflow.sweeps.slurm import main\nmain({list(args)!r})"
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


@pytest.fixture
def grid(tmp_path):
    out = tmp_path / "grid"
    assert main(["sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--init",
                 "--out", str(out)]) == 0
    return out


def test_the_job_scripts_python_is_one_shell_word_whatever_its_path(grid, tmp_path):
    """A python under a path with a space, or holding "$(...)", is one word of the job
    script's command: the path is not split, and the command inside it never runs."""
    pwned = tmp_path / "pwned"
    odd = f"{tmp_path}/my env/$(touch {pwned})/bin/python"
    env = fake_scheduler(tmp_path, {"squeue": "exit 0"})
    sub = _slurm(["submit", "--pretend", "--bundle", "2"], grid, env,
                   prelude=f"import sys; sys.executable = {odd!r}")
    assert sub.returncode == 0, sub.stderr
    lines = [ln for ln in sub.stdout.splitlines() if "-m bkflow.slurm run" in ln]
    assert len(lines) == 2
    for line in lines:
        words = shlex.split(line.rstrip("&").strip())
        assert words[0] == odd and words[1:4] == ["-m", "bkflow.slurm", "run"]
        # the shell reads the line as shlex does: echo it through bash, nothing is run
        echoed = subprocess.run(["bash", "-c", "printf '%s\\n' " + line.rstrip("&").strip()],
                                capture_output=True, text=True, check=True).stdout
        assert echoed.splitlines()[0] == odd
    assert not pwned.exists()


def test_an_operation_that_does_not_exist_is_refused(grid, tmp_path):
    env = {**os.environ, "SIGNAC_FLOW_ENVIRONMENT": "StandardEnvironment"}
    for args in (["run", "-o", "simulat"], ["run", "--operation=analyse"],
                 ["status", "-o", "simulate", "nothing"]):
        r = _slurm(args, grid, env)
        assert r.returncode == 2, (args, r.stderr)
        assert "no operation" in r.stderr and "analyze, simulate" in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1
    assert not any(finished(j) for j in open_project(grid, create=False))  # nothing ran
    # flow reads -o as a regular expression matched whole: one that matches is no typo
    for pattern in ("sim.*", "simulate|analyze"):
        r = _slurm(["status", "-o", pattern], grid, env)
        assert "no operation" not in r.stderr, (pattern, r.stderr)


def test_submit_without_a_scheduler_advises_a_command_that_works(lammps, grid, tmp_path):
    """Without a scheduler, submit (--pretend too) advises running the jobs here; that
    advice, followed as printed, runs them (it does not advise the environment in use)."""
    env = {**os.environ, "SIGNAC_FLOW_ENVIRONMENT": "StandardEnvironment"}
    r = _slurm(["submit", "--pretend"], grid, env)
    assert r.returncode == 1
    line, = r.stderr.strip().splitlines()
    assert "submit needs a working batch scheduler" in line
    advised = line.split("run the jobs here instead, ", 1)[1].rstrip(")")
    words = shlex.split(advised)
    assigned = dict(w.split("=", 1) for w in words if "=" in w and not w.startswith("-"))
    command = [w for w in words if w not in {f"{k}={v}" for k, v in assigned.items()}]
    # the python that has bkflow, as the job scripts call it, not whichever "python" is first
    assert command[:3] == [sys.executable, "-m", "bkflow.slurm"]
    done = subprocess.run(command, cwd=grid, env={**env, **assigned},
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert all(finished(j) for j in open_project(grid, create=False)), done.stderr[-2000:]


def test_run_exits_1_when_its_runs_failed(grid, tmp_path):
    """A run that fails is kept in its job document and the others go on; the command then
    exits 1 with the first failure (it exited 0, and a job script looked fine). Without the
    lammps fixture the plugin is hidden, so every run fails."""
    env = {**os.environ, "SIGNAC_FLOW_ENVIRONMENT": "StandardEnvironment"}
    r = _slurm(["run"], grid, env)
    assert r.returncode == 1
    assert "2 run(s) failed; the first: PluginError" in r.stderr.strip().splitlines()[-1]
    # only this pass's failures count: --pretend runs nothing, and says nothing failed
    assert _slurm(["run", "--pretend"], grid, env).returncode == 0


def test_the_old_name_still_runs_the_command(grid):
    """``python -m bkflow.cluster`` (the name job scripts submitted before bkflow 0.6 call)
    runs ``python -m bkflow.slurm``: the same status of the same sweep."""
    env = {**os.environ, "SIGNAC_FLOW_ENVIRONMENT": "StandardEnvironment"}
    new, old = (subprocess.run([sys.executable, "-m", name, "status"], cwd=grid, env=env,
                               capture_output=True, text=True, timeout=300)
                for name in ("bkflow.slurm", "bkflow.cluster"))
    assert new.returncode == old.returncode == 0, (new.stderr, old.stderr)
    assert new.stdout == old.stdout and "simulate" in new.stdout
