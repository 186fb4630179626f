"""What a run or a sweep will cost, checked against what this machine can give before
anything is created (bkflow run and sweep refuse above the limits unless --force); and how
many processes an MPI launcher started bkflow as (it is one: ``mpi_refusal``).

The estimates are deliberately simple and a little generous:

- work: atom-steps, N * n_steps, twice that with a companion run (which runs beside the run,
  step for step); the time is said at ``ATOM_STEPS_PER_SECOND``;
- memory: about 2 kB per atom for LAMMPS and the engine (twice with a companion), and for the
  analysis the frames of the dumps it reads at once (16 bytes per atom and frame) and the
  run's reduced records;
- disk: the reduced records (``RECORD_BYTES_PER_T`` a time unit, more with the ledger; Psi's
  16 bytes a snapshot), the raw series where the scene keeps them (60 bytes a stress sample),
  the snapshots of scene full (50 bytes per atom and frame) and the slip frames (two per slip,
  at most SLIPS_PER_T = 0.08 slips a time unit after the transient), and the fronts (4 bytes a
  particle at every stress sample through a slip: FRONT_SHARE).
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec
from bkflow.store.layout import DECK

#: the rate at which the time of a run is estimated: one core runs the fused path at 6e7 (N =
#: 230400, out of the caches) to 1.7e8 atom-steps a second (N = 900 to 57600) and 3-4e7 at N =
#: 100 (benchmarks/measure/throughput.py; its --scaling measurement is
#: benchmarks/report/scaling_model.py's MEASURED), the general path at 3-5e7: generous
#: for the fused path (a run at N = 14400 takes about a third of the time said)
ATOM_STEPS_PER_SECOND = 5e7
#: one run (with its companion) may take at most this many atom-steps (about an hour of one
#: core at ATOM_STEPS_PER_SECOND) unless forced
MAX_ATOM_STEPS = 2e11
#: a run may need at most this share of the memory available now
MAX_MEMORY_SHARE = 0.5
#: a run or a sweep may write at most this share of the free disk, and never more than
MAX_DISK_SHARE, MAX_BYTES = 0.5, 20e9
#: a sweep may hold at most this many runs unless forced
MAX_RUNS = 5000
#: a sweep may start at most this many processes per core unless forced
MAX_JOBS_PER_CORE = 4


class CostError(SpecError):
    """A request above the limits of this machine (lifted with --force)."""


@dataclass(frozen=True)
class Cost:
    atom_steps: float
    memory_bytes: float
    disk_bytes: float
    #: of these, the frames' (snapshots, slip frames): what --scene friction does away with
    frame_bytes: float = 0.0
    frame_memory: float = 0.0
    #: the raw series' bytes (scenes series, full): what a scene without them does away with
    series_bytes: float = 0.0
    #: the reduced records the analysis reads at once
    record_memory: float = 0.0

    def __add__(self, other: Cost) -> Cost:
        big = self if self.memory_bytes >= other.memory_bytes else other
        return Cost(self.atom_steps + other.atom_steps, big.memory_bytes,
                    self.disk_bytes + other.disk_bytes, self.frame_bytes + other.frame_bytes,
                    big.frame_memory, self.series_bytes + other.series_bytes,
                    big.record_memory)


#: bytes a run's reduced records take per time unit, at most (extrema.npy: up to ~0.6 turning
#: points a time unit at the extrema threshold, 16 bytes each, 80 with the ledger; blocks.npy:
#: 80 bytes a block of BLOCK_EVERY, 144 with the ledger); with the slips' rows of the default
#: scene (slips.npy, clusters.npy: 96 and 80 bytes a slip, up to ~0.1 slips a time unit at
#: phi = 1000) SLIP_ROW_BYTES_PER_T more; benchmarks/measure/scene_costs.py, its record
#: benchmarks/records/scene_bytes.json
RECORD_BYTES_PER_T = 16.0
RECORD_BYTES_PER_T_LEDGER = 60.0
SLIP_ROW_BYTES_PER_T = 20.0
#: fronts.bin (scenes fronts, full): 4 bytes a particle at every stress sample through a slip
#: after the transient. The share of that time spent slipping, measured at N = 100 (t_end
#: 4000, paper's protocol): 0.52 at phi <= 10, 0.41 at 100, 0.21 at 1000, as
#: FRONT_SHARE / (1 + phi / FRONT_PHI); a slip lasts at most FRONT_SAMPLES samples (77 at
#: phi = 1, 27 at 1000), which bounds the full scene's FRONTS_IN_FULL slips
#: (tests/cli/test_fault_classes.py checks every scene's estimate within 2x of what it writes)
FRONT_SHARE = 0.52
#: slips a time unit after the transient, the most measured (N = 100, paper's protocol, t_end
#: 4000: 0.063 at phi = 10, 0.068 at 1, 0.08 at 100 and 1000; the rows' bytes above allow
#: for up to 0.1)
SLIPS_PER_T = 0.08
FRONT_PHI = 700.0
FRONT_SAMPLES = 80.0


def cost(spec: RunSpec) -> Cost:
    """The estimated cost of one run (see module doc)."""
    n, steps = spec.N, spec.n_steps
    samples = steps / spec.stress_nevery + 1
    psi = steps / spec.snapshot_nevery + 1 if spec.writes_snapshots else 0
    snapshots = psi if spec.writes_frames else 0
    # two frames a slip, at most SLIPS_PER_T slips a time unit after the transient
    slips = 2 * (1 - spec.transient) * spec.t_end * SLIPS_PER_T if spec.writes_slip_frames else 0
    frames, frame_memory = 50.0 * n * (snapshots + slips), 16.0 * n * max(snapshots, slips)
    runs = 1 if spec.companion is None else 2  # the companion: its records, its data
    per_t = RECORD_BYTES_PER_T_LEDGER if spec.writes_energy else RECORD_BYTES_PER_T
    if spec.writes_slips and not spec.writes_slip_frames:
        per_t += SLIP_ROW_BYTES_PER_T
    records = per_t * spec.t_end + 16.0 * psi   # what the analysis reads at once
    # stress.npy (16 bytes a sample, 80 with the ledger) and phase.npy
    series = (80.0 if spec.writes_energy else 24.0) * samples if spec.writes_series else 0.0
    fronts = 0.0
    if spec.writes_fronts:
        after = (1 - spec.transient) * (samples - 1)
        fronts = 4.0 * n * after * FRONT_SHARE / (1 + spec.phi / FRONT_PHI)
        if spec.fronts_limit is not None:
            fronts = min(fronts, 4.0 * n * FRONT_SAMPLES * spec.fronts_limit)
    frames += fronts   # written once, read one slip at a time: disk, not memory
    disk = records + (runs - 1) * per_t * spec.t_end + runs * 120.0 * n + series + frames
    memory = 2e3 * n * runs + frame_memory + records
    return Cost(float(n) * steps * runs, memory, disk, frames, frame_memory, series, records)


def _available_memory() -> float:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def _free_disk(path) -> float:
    p = Path(path).absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return float(shutil.disk_usage(p).free)
    except OSError:
        return float("inf")


def fmt_bytes(b: float) -> str:
    for unit, f in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if b >= f:
            return f"{b / f:.3g} {unit}"
    return f"{b:.0f} B"


def check(c: Cost, out, what: str, force: bool = False) -> None:
    """Raise CostError when ``c`` is above a limit, naming it and how to lift it."""
    if force:
        return
    hint = "; pass --force to run it anyway"
    mem = _available_memory()
    if c.memory_bytes > MAX_MEMORY_SHARE * mem:
        fix = ("choose --scene friction or shorten --t-end (the analysis reads the frames at "
               "once)" if c.frame_memory > c.memory_bytes / 2 else
               "shorten --t-end (the analysis reads the run's records at once)"
               if c.record_memory > c.memory_bytes / 2 else "use a smaller lattice")
        raise CostError(f"{what} needs about {fmt_bytes(c.memory_bytes)} of memory, more than half "
                        f"of the {fmt_bytes(mem)} available: {fix}{hint}")
    free = _free_disk(out)
    if free == 0:   # a full or pseudo file system (/proc): the file system's refusal
        import errno

        raise OSError(errno.ENOSPC, "no space left on its file system (nothing can be "
                      "written there)", str(out))
    if c.disk_bytes > min(MAX_BYTES, MAX_DISK_SHARE * free):
        fix = ("choose --scene friction (no frames)" if c.frame_bytes > c.disk_bytes / 2 else
               "choose a scene without the raw series (--scene friction) or sample the stress "
               "less often (--set stress_every=...)" if c.series_bytes > c.disk_bytes / 2 else
               "shorten --t-end")
        raise CostError(f"{what} would write about {fmt_bytes(c.disk_bytes)}, more than "
                        f"{fmt_bytes(min(MAX_BYTES, MAX_DISK_SHARE * free))} (half the free disk "
                        f"at {out}, at most {fmt_bytes(MAX_BYTES)}): {fix}, or another --out{hint}")
    if c.atom_steps > MAX_ATOM_STEPS:
        hours = c.atom_steps / ATOM_STEPS_PER_SECOND / 3600
        hours = f"{hours:.2g}" if hours < 100 else f"{hours:,.0f}"
        raise CostError(f"{what} is {c.atom_steps:.3g} atom-steps, up to {hours} h of one "
                        f"core (limit {MAX_ATOM_STEPS:.0e}): shorten --t-end, raise "
                        f"--dt-factor or use a smaller lattice{hint}")


def within_limits(spec: RunSpec, out) -> str | None:
    """Why one run of ``spec`` into ``out`` is above the limits (``check``'s message), or
    None when it is within them."""
    try:
        check(cost(spec), out, "it")
    except CostError as exc:   # the limit it passes, without the advice of a refusal
        return str(exc).split(": ")[0].split(" (")[0]
    except OSError:
        return "no space left where it would be written"
    return None


def longest_run(spec: RunSpec, out, t_max: float) -> float | None:
    """The longest t_end (at most ``t_max``, to 2 significant digits) at which a run of
    ``spec`` into ``out`` is within the limits; None when not even spec.t_end is."""
    if within_limits(spec, out) is not None:
        return None
    lo, hi = spec.t_end, t_max
    if within_limits(spec.replace(t_end=hi), out) is None:
        return hi
    for _ in range(40):   # the cost grows with t_end: bisect in log t
        mid = (lo * hi) ** 0.5
        if within_limits(spec.replace(t_end=mid), out) is None:
            lo = mid
        else:
            hi = mid
    return float(f"{lo:.2g}") if float(f"{lo:.2g}") <= lo else float(f"{lo * 0.95:.2g}")


def check_cost(spec: RunSpec, out, force: bool = False) -> Cost:
    """The cost of one run, refused above the limits unless ``force``."""
    c = cost(spec)
    also = "" if spec.companion is None else " and as many for its companion"
    check(c, out, f"this run ({spec.label}, {spec.n_steps} steps{also})", force)
    return c


def check_run_count(n: int, force: bool = False) -> None:
    """A sweep of ``n`` runs, refused above MAX_RUNS unless ``force`` (counted before a run's
    parameters are built, so an absurd grid is refused at once)."""
    if n > MAX_RUNS and not force:
        raise CostError(f"this sweep has {n} runs (limit {MAX_RUNS}): fewer phi "
                        "(--points-per-decade), sizes or seeds; pass --force to run it anyway")


def check_sweep(specs, out, jobs: int, cores: int, force: bool = False) -> Cost:
    """The cost of a sweep: the number of runs, the processes, every run's own limits and
    the disk of all of them together."""
    specs = list(specs)
    if force:
        return sum((cost(s) for s in specs), Cost(0, 0, 0))
    check_run_count(len(specs))
    if jobs > MAX_JOBS_PER_CORE * cores:
        raise CostError(f"--jobs {jobs} starts more than {MAX_JOBS_PER_CORE} processes per core "
                        f"on this {cores}-core machine; pass --force to run it anyway")
    total = Cost(0, 0, 0)
    for s in specs:
        total = total + check_cost(s, out)
    check(Cost(0, 0, total.disk_bytes, total.frame_bytes), out,
          f"this sweep of {len(specs)} runs")
    return total


#: the variables in which MPI launchers tell each process how many were started: MPICH's and
#: Intel MPI's hydra (and srun's PMI-2), Open MPI, MVAPICH, PMIx (srun --mpi=pmix)
MPI_SIZE_VARS = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MV2_COMM_WORLD_SIZE", "PMIX_SIZE")


def mpi_world_size(env=os.environ) -> int:
    """How many processes an MPI launcher started with this one (1 when none did): the
    largest count any launcher's variable gives (one inherited from an outer ``srun -n 1``
    must not hide Open MPI's). bkflow is one process: its runs are single-rank LAMMPS
    instances, and K copies under ``mpirun -np K`` would share one MPI world and wait on each
    other forever."""
    counts = [int(v) for v in (env.get(var, "").strip() for var in MPI_SIZE_VARS)
              if v.isascii() and v.isdigit()]
    return max(counts + [1])


def mpi_refusal(env=os.environ) -> str | None:
    """Why bkflow stops when an MPI launcher started it as more than one process, and what to
    do instead; None when it was started once (``mpi_world_size``)."""
    launched = mpi_world_size(env)
    if launched < 2:
        return None
    return (f"bkflow was started as {launched} MPI processes (mpirun -np {launched}), which "
            "would all write the same run and wait on each other: start it once (a sweep runs "
            "its runs side by side with --jobs J, a cluster's with its job scripts); to run "
            "one lattice on K ranks: bkflow deck ... --out DIR, then cd DIR && mpirun -np K "
            f"lmp -in {DECK} (docs/slurm.md)")
