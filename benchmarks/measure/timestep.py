"""Work-precision of the time step: the bias of the steady observables against dt, per phi and
size, over the whole stable range; the time-step rule and the presets are derived from it
(docs/model.md "Integration", bkflow.model.params.time_step).

    python -m benchmarks.measure.timestep [--n 100] [--phi ...] [--c ...] [--seeds 1,2,3,4]
                                          [--shard I/K] [--no-presets]

For each phi, C = dt omega_max (omega_max^2 = (4 k_b + k_e + k_d + dk_d) / m) and seed: one run
from the random start of T_SOFT time units (phi <= 10) or T_STIFF (phi > 10, where the states
switch slowly), recorded in blocks (``longrun.LongRun``, benchmarks/records/timestep/),
resumable; beside the grid of C, each accuracy preset's own step (unless --no-presets). A C
whose plate moves more than MAX_DRIVE_STEP a step is left out (bkflow refuses it).

The report (``python -m benchmarks.report.timestep``): per (phi, N, C), the bias of
<sigma_x>/sigma_n and of mu_bar (1% threshold) after the first 20% of the run, against the
smallest C of that phi (C_REF_SOFT or C_REF_STIFF), relative; each the mean over seeds of the
paired difference (same seed: the same disorder k_d^i and start), with its standard error over
seeds; the cost in atom-steps per time unit.
"""

from __future__ import annotations

from benchmarks.harness import RECORDS, add_shard, floats, ints, parser, print_progress, shard
from benchmarks.measure.longrun import LongRun, case_name
from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec, size_from_n
from bkflow.model.timestep import ACCURACY

OUT = RECORDS / "timestep"
PHI = (0.1, 0.464, 2.15, 10.0, 46.4, 215.0, 1000.0)
C_VALUES = (0.025, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0, 1.5, 1.9)
#: the references: the smallest C run at each end
C_REF_SOFT, C_REF_STIFF = 0.025, 0.05
#: phi above which runs are T_STIFF long, and start at C_REF_STIFF
PHI_STIFF = 10.0
T_SOFT, T_STIFF = 2e4, 1e5


def run_length(phi: float) -> float:
    return T_STIFF if phi > PHI_STIFF else T_SOFT


def _c_of(spec: RunSpec) -> float:
    return spec.dt * spec.omega_max


def preset_cs(n: int, phi: float) -> list[float]:
    """The C = omega_max dt of each accuracy preset's rule at (N, phi), to 4 digits: run beside
    the grid, so that each preset is measured at its own step, not interpolated."""
    Lx, Ly = size_from_n(n)
    return sorted({round(_c_of(RunSpec(phi=phi, Lx=Lx, Ly=Ly, accuracy=name)), 4)
                   for name in ACCURACY})


def cases(n: int, phis, cs, seeds, presets: bool = True):
    Lx, Ly = size_from_n(n)
    for seed in seeds:
        for phi in phis:
            extra = [c for c in preset_cs(n, phi) if presets and c not in cs]
            for c in sorted([*cs, *extra]):
                if phi > PHI_STIFF and c < C_REF_STIFF:
                    continue
                try:
                    spec = RunSpec(phi=phi, Lx=Lx, Ly=Ly, seed=seed, start="random",
                                   dt_factor=c)
                except SpecError:  # the plate would move more than MAX_DRIVE_STEP a step
                    continue
                yield spec


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--phi", type=floats, default=list(PHI))
    ap.add_argument("--c", type=floats, default=list(C_VALUES))
    ap.add_argument("--seeds", type=ints, default=[1, 2, 3, 4])
    add_shard(ap)
    ap.add_argument("--no-presets", dest="presets", action="store_false",
                    help="only the grid of C, not each preset's own step")
    a = ap.parse_args(argv)
    for spec in shard(cases(a.n, a.phi, a.c, a.seeds, a.presets), a.shard):
        LongRun(spec, OUT / f"{case_name(spec)}.parquet", 1000.0,
                chunk_t=min(1e5, run_length(spec.phi))).advance_to(
            run_length(spec.phi), log=print_progress)


if __name__ == "__main__":
    main()
