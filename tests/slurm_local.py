"""A one-node SLURM for the tests, started and stopped by them: Debian's munge, slurmctld and
slurmd, configured for this host in a temporary directory, on ports of its own, every daemon
started in the foreground by us and stopped by its PID, also when the test fails.

Installing the packages changes the machine (apt-get installs them system-wide, and Debian's
packaging may start their services), so it is opt-in: only ``pytest --install-slurm`` (what CI
runs, as root) installs them when they are missing. A plain ``pytest`` uses SLURM only where
it is installed already, and otherwise skips its tests, saying how to opt in."""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import time
from pathlib import Path

PACKAGES = ("slurmctld", "slurmd", "slurm-client", "munge")
DAEMONS = ("/usr/sbin/munged", "/usr/sbin/slurmctld", "/usr/sbin/slurmd")
#: the pytest option (tests/conftest.py) that lets the SLURM tests install the packages
INSTALL_OPTION = "--install-slurm"


def why_not(may_install: bool = False) -> str | None:
    """Why a local SLURM cannot be had here (None: it can). ``may_install``: install the
    Debian packages when they are missing (``pytest --install-slurm``); without it nothing is
    installed."""
    if os.name != "posix" or os.geteuid() != 0:
        return "needs root (CI runs as root) to start SLURM's daemons"
    if all(Path(d).exists() for d in DAEMONS) and shutil.which("sbatch"):
        return None
    if not may_install:
        return (f"SLURM is not installed; pytest {INSTALL_OPTION} installs Debian's "
                f"{', '.join(PACKAGES)} with apt-get (system-wide) to run these tests")
    if not shutil.which("apt-get"):
        return "SLURM is not installed and this is not a Debian-like system (no apt-get)"
    return install()


def install() -> str | None:
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    cmd = ["apt-get", "install", "-y", "-q", "--no-install-recommends", *PACKAGES]
    for attempt in range(2):
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
        if proc.returncode == 0:
            return None
        if attempt == 0:  # stale package lists: refresh them once
            subprocess.run(["apt-get", "update", "-q"], env=env, capture_output=True,
                           timeout=600)
    return f"apt-get install {' '.join(PACKAGES)} failed: {proc.stderr.strip()[-300:]}"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _config(d: Path, host: str, cpus: int) -> str:
    ctl, node = _free_port(), _free_port()
    return "\n".join([
        "ClusterName=bkflowtest",
        f"SlurmctldHost={host}",
        "SlurmUser=root", "SlurmdUser=root",
        "AuthType=auth/munge", f"AuthInfo=socket={d / 'munge.socket'}",
        "CredType=cred/munge",
        f"SlurmctldPort={ctl}", f"SlurmdPort={node}",
        f"StateSaveLocation={d / 'state'}", f"SlurmdSpoolDir={d / 'spool'}",
        f"SlurmctldPidFile={d / 'slurmctld.pid'}", f"SlurmdPidFile={d / 'slurmd.pid'}",
        f"SlurmctldLogFile={d / 'slurmctld.log'}", f"SlurmdLogFile={d / 'slurmd.log'}",
        "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none",
        "SelectType=select/cons_tres", "SelectTypeParameters=CR_Core",
        "SchedulerType=sched/builtin", "ReturnToService=2", "MpiDefault=none",
        "JobAcctGatherType=jobacct_gather/none",
        "AccountingStorageType=accounting_storage/none",
        "MinJobAge=3600", "KillWait=2", "InactiveLimit=0",
        f"NodeName={host} CPUs={cpus} State=UNKNOWN",
        f"PartitionName=debug Nodes={host} Default=YES MaxTime=INFINITE State=UP",
        "",
    ])


@contextlib.contextmanager
def local_slurm(d: Path, cpus: int = 2, timeout: float = 60.0):
    """Start munged, slurmctld and slurmd configured in directory ``d``; yield the
    environment (SLURM_CONF) for the client commands; stop them all by PID at the end."""
    d = Path(d)
    for sub in ("state", "spool"):
        (d / sub).mkdir(parents=True, exist_ok=True)
    host = socket.gethostname().split(".")[0]
    conf = d / "slurm.conf"
    conf.write_text(_config(d, host, cpus))
    env = {**os.environ, "SLURM_CONF": str(conf)}
    procs: list[subprocess.Popen] = []
    logs = []
    try:
        key = d / "munge.key"
        key.write_bytes(os.urandom(128))
        key.chmod(0o400)
        log = open(d / "daemons.log", "w")
        logs.append(log)
        procs.append(subprocess.Popen(
            ["/usr/sbin/munged", "--foreground", "--force", f"--socket={d / 'munge.socket'}",
             f"--key-file={key}", f"--pid-file={d / 'munged.pid'}",
             f"--log-file={d / 'munged.log'}", f"--seed-file={d / 'munged.seed'}"],
            stdout=log, stderr=subprocess.STDOUT))
        _wait(lambda: (d / "munge.socket").exists(), timeout, "munged did not start", d)
        procs.append(subprocess.Popen(["/usr/sbin/slurmctld", "-D", "-i", "-f", str(conf)],
                                      env=env, stdout=log, stderr=subprocess.STDOUT))
        procs.append(subprocess.Popen(["/usr/sbin/slurmd", "-D", "-f", str(conf)], env=env,
                                      stdout=log, stderr=subprocess.STDOUT))

        def idle():
            out = subprocess.run(["sinfo", "-h", "-o", "%T"], env=env, capture_output=True,
                                 text=True, timeout=30)
            return out.returncode == 0 and "idle" in out.stdout

        _wait(idle, timeout, "the node did not come up idle", d)
        yield env
    finally:
        for p in reversed(procs):
            with contextlib.suppress(ProcessLookupError):
                p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout=15)
        for log in logs:
            log.close()


def _wait(ready, timeout: float, what: str, d: Path) -> None:
    t0 = time.monotonic()
    while not ready():
        if time.monotonic() - t0 > timeout:
            tail = ""
            for name in ("daemons.log", "slurmctld.log", "slurmd.log", "munged.log"):
                f = d / name
                if f.exists():
                    tail += f"\n--- {name}\n" + "\n".join(f.read_text().splitlines()[-15:])
            raise RuntimeError(f"local SLURM: {what} within {timeout:g} s{tail}")
        time.sleep(0.25)


def squeue(env) -> list[str]:
    out = subprocess.run(["squeue", "-h", "-o", "%i %T %j"], env=env, capture_output=True,
                         text=True, timeout=30, check=True)
    return [ln for ln in out.stdout.splitlines() if ln.strip()]


def jobs(env) -> dict[str, tuple[str, str]]:
    """{job id: (job name, state)} of every job slurmctld remembers (MinJobAge = 1 h)."""
    out = subprocess.run(["scontrol", "-o", "show", "job"], env=env, capture_output=True,
                         text=True, timeout=30)
    found = {}
    for line in out.stdout.splitlines():
        f = dict(tok.split("=", 1) for tok in line.split() if "=" in tok)
        if "JobId" in f:
            found[f["JobId"]] = (f.get("JobName", ""), f.get("JobState", ""))
    return found


def job_state(env, job_id: str) -> str:
    out = subprocess.run(["scontrol", "show", "job", job_id], env=env, capture_output=True,
                         text=True, timeout=30)
    for tok in out.stdout.split():
        if tok.startswith("JobState="):
            return tok.split("=", 1)[1]
    return "UNKNOWN"
