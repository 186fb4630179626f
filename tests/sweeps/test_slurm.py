"""The cluster path for real: a one-node SLURM (tests/slurm_local.py) runs a sweep submitted
with ``python -m bkflow.slurm submit --bundle 2 --parallel``; a re-submission queues
nothing; a job cancelled mid-run is redone by the next submission. Skipped (saying why) where
SLURM cannot be started: not root, or SLURM not installed (``pytest --install-slurm``, what CI
runs, installs Debian's packages first; a plain ``pytest`` installs nothing)."""

import re
import subprocess
import sys
import time

import pytest

from bkflow.cli.commands import main
from bkflow.store.layout import EXTREMA, META
from bkflow.sweeps.project import finished, open_project
from tests import slurm_local
from tests.slurm_local import INSTALL_OPTION, jobs, local_slurm, squeue, why_not


@pytest.fixture(scope="module")
def slurm(lammps, tmp_path_factory, request):
    why = why_not(may_install=request.config.getoption(INSTALL_OPTION))
    if why is not None:
        pytest.skip(why)
    with local_slurm(tmp_path_factory.mktemp("slurm")) as env:
        yield {**env, "SIGNAC_FLOW_ENVIRONMENT": "DefaultSlurmEnvironment"}


def _submit(sweep_dir, env, *extra) -> dict[str, str]:
    """Submit the sweep's eligible runs; {SLURM job id: job name} of the jobs it queued."""
    before = set(jobs(env))
    proc = subprocess.run([sys.executable, "-m", "bkflow.slurm", "submit", *extra],
                          cwd=sweep_dir, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    names = re.findall(r"Submitting cluster job '([^']+)'", proc.stdout + proc.stderr)
    new = {i: n for i, (n, _) in jobs(env).items() if i not in before}
    assert len(new) == len(names), (new, names)
    return new


def _states(env, ids) -> list[str]:
    known = jobs(env)
    return [known[i][1] for i in sorted(ids)]


def _wait_until(ready, timeout=240.0, what="") -> None:
    t0 = time.monotonic()
    while not ready():
        assert time.monotonic() - t0 < timeout, f"timed out waiting: {what}"
        time.sleep(0.5)


def _grid(out, *args):
    assert main(["sweep", *args, "--scene", "friction", "--init", "--out", str(out)]) == 0
    return open_project(out, create=False)


@pytest.mark.slurm
@pytest.mark.slow
def test_a_sweep_runs_on_slurm_and_a_resubmission_queues_nothing(slurm, tmp_path):
    out = tmp_path / "grid"
    project = _grid(out, "--phi", "1,10", "--seeds", "2", "--t-end", "100")
    ids = _submit(out, slurm, "--bundle", "2", "--parallel")
    assert len(ids) == 2  # 4 runs in bundles of 2
    _wait_until(lambda: not squeue(slurm), what="the sweep's jobs to leave the queue")
    assert _states(slurm, ids) == ["COMPLETED", "COMPLETED"]
    assert sum(finished(j) for j in project) == 4
    assert _submit(out, slurm, "--bundle", "2", "--parallel") == {}
    assert not squeue(slurm)


@pytest.mark.slurm
@pytest.mark.slow
def test_a_job_cancelled_mid_run_is_redone(slurm, tmp_path):
    out = tmp_path / "grid"
    project = _grid(out, "--phi", "100", "--sizes", "60x15", "--seeds", "1", "--t-end", "6000",
                    "--dt-factor", "0.1")
    job = next(iter(project))
    ids = _submit(out, slurm)
    assert len(ids) == 1
    # cancel once the run is under way (its records are being written)
    _wait_until(lambda: (out / "workspace" / job.id / EXTREMA).exists(), what="the run to start")
    subprocess.run(["scancel", *ids], env=slurm, check=True, timeout=30)
    _wait_until(lambda: not squeue(slurm), what="the cancelled job to leave the queue")
    assert _states(slurm, ids) == ["CANCELLED"]
    assert not (out / "workspace" / job.id / META).exists() and not finished(job)
    again = _submit(out, slurm)
    assert len(again) == 1
    _wait_until(lambda: not squeue(slurm), what="the resubmitted job")
    assert _states(slurm, again) == ["COMPLETED"]
    assert finished(job)


@pytest.mark.parametrize("opted_in", [False, True])
def test_slurm_is_installed_only_when_asked(opted_in, monkeypatch):
    """As root on Debian without SLURM, a plain ``pytest`` installs nothing (apt-get changes
    the system, and Debian's packaging may start services): the tests are skipped, naming
    ``--install-slurm``; with the option the packages are installed."""
    calls = []
    monkeypatch.setattr(slurm_local.os, "geteuid", lambda: 0)
    monkeypatch.setattr(slurm_local.shutil, "which",
                        lambda name: "/usr/bin/apt-get" if name == "apt-get" else None)
    monkeypatch.setattr(slurm_local, "install", lambda: calls.append("apt-get install"))
    why = why_not(may_install=opted_in)
    if opted_in:
        assert why is None and calls == ["apt-get install"]
    else:
        assert calls == [] and INSTALL_OPTION in why
