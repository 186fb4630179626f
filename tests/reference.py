"""Independent NumPy implementation of the model (docs: the model), for checking the LAMMPS plugin.

Written from docs/model.md, not from the plugin's source, with LAMMPS's order of operations
(velocity Verlet as in ``fix nve``; post-force terms with the half-step velocity):

    v += dt/2 f / m ;  x += dt v                        (initial_integrate, t -> t + dt)
    f  = bonds(x) + drive(x, t) + friction(v) + damping(v)   (forces at t_{n+1})
    v += dt/2 f / m                                      (final_integrate)

Before the first step, forces are evaluated once from the initial state without advancing the
contact history (LAMMPS's ``setup``). Positions are kept unwrapped. The bond network never
changes (docs/model.md): each bond keeps the periodic image it has on the initial lattice, as a
fixed shift S_ij taken once from the minimum image of the start, d_ij = x_i - x_j + S_ij.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class ReferenceState:
    x: np.ndarray        # (N, 2) unwrapped positions
    v: np.ndarray        # (N, 2) velocities
    dr: np.ndarray       # (N, 2) contact displacements
    anchor: np.ndarray   # (N, 2) drive anchors at t0
    t: float = 0.0       # time since the anchors were taken
    breaks: int = 0
    # breaks the contact rule left past the threshold (the step carried them further than the
    # rule brings back); coulomb puts every one on the threshold itself: none
    overshoot: int = 0
    f: np.ndarray = field(default=None)
    # the energy ledger (docs/model.md "Energy"), running sums since the start
    work_plate: float = 0.0   # work of the plate on the drive springs' anchors
    diss_break: float = 0.0   # contact energy lost at breaks (reset) or by sliding (coulomb)
    diss_damp: float = 0.0    # dissipated by the damping force
    f_damp: np.ndarray = field(default=None)  # the damping part of f


@dataclass(frozen=True)
class Ledger:
    """The energy of a state and what crossed its boundary since the start (docs/model.md
    "Energy"): elastic (bonds, drive springs, contacts), kinetic, the plate's work, and the
    dissipation by contact breaks and by damping. ``residual`` = plate work - (elastic +
    kinetic - their start) - dissipation: zero up to the integrator's error."""

    bond: float
    drive: float
    contact: float
    kinetic: float
    work_plate: float
    diss_break: float
    diss_damp: float

    @property
    def elastic(self) -> float:
        return self.bond + self.drive + self.contact

    @property
    def energy(self) -> float:
        return self.elastic + self.kinetic

    def residual(self, start: Ledger) -> float:
        return (self.work_plate - start.work_plate) - (self.energy - start.energy) \
            - (self.diss_break - start.diss_break) - (self.diss_damp - start.diss_damp)


class Reference:
    """The model on a periodic box ``box = (Lx, Ly)`` with 0-based ``bonds`` (M, 2).

    ``k_b`` bond stiffness (force k_b (r - l)), ``k_d`` (N,) drive stiffnesses (None: no
    drive), ``k_e`` / ``f_max`` contact spring and threshold (None: no friction), ``mode``
    'reset' (the break located inside the step: the contact re-forms where |dr| crosses the
    threshold and keeps the rest of the step's motion), 'reset/step' (dr = 0 at the end of the
    step) | 'coulomb', ``gamma`` damping rate, ``damping`` 'implicit' (the force -m gamma v
    with v the end-of-step velocity, solved for) | 'half' (the half-step velocity), ``V_d``
    plate velocity, ``mass``.
    """

    def __init__(self, box, bonds, k_b, dt, *, k_d=None, V_d=0.0, k_e=None, f_max=None,
                 mode="reset", gamma=0.0, mass=1.0, r0=1.0, damping="implicit"):
        self.L = np.asarray(box, dtype=float)
        self.bonds = np.asarray(bonds)
        self.k_b, self.dt, self.r0 = k_b, dt, r0
        self.k_d = None if k_d is None else np.asarray(k_d, dtype=float)
        self.V_d, self.k_e, self.f_max = V_d, k_e, f_max
        if mode not in ("reset", "reset/step", "coulomb"):
            raise ValueError(mode)
        if damping not in ("implicit", "half"):
            raise ValueError(damping)
        self.mode, self.gamma, self.mass, self.damping = mode, gamma, mass, damping

    # forces ---------------------------------------------------------------------------
    def bond_vectors(self, x):
        i, j = self.bonds[:, 0], self.bonds[:, 1]
        return x[i] - x[j] + self.shift

    def bond_forces(self, x):
        i, j = self.bonds[:, 0], self.bonds[:, 1]
        d = self.bond_vectors(x)
        r = np.sqrt((d * d).sum(axis=1))
        fpair = (-self.k_b * (r - self.r0) / r)[:, None] * d
        f = np.zeros_like(x)
        np.add.at(f, i, fpair)
        np.add.at(f, j, -fpair)
        return f

    def bond_energy(self, x):
        d = self.bond_vectors(x)
        r = np.sqrt((d * d).sum(axis=1))
        return 0.5 * self.k_b * ((r - self.r0) ** 2).sum()

    def substrate_forces(self, s: ReferenceState, v, advance: bool, f_other):
        f = np.zeros_like(s.x)
        if self.k_d is not None:
            target = s.anchor + np.array([self.V_d * s.t, 0.0])
            f += self.k_d[:, None] * (target - s.x)
        if self.k_e is not None:
            if advance:
                old = s.dr
                w = v * self.dt
                s.dr = old + w
                over = self.k_e * np.sqrt((s.dr ** 2).sum(axis=1)) > self.f_max
                s.breaks += int(over.sum())
                before = 0.5 * self.k_e * (s.dr[over] ** 2).sum()
                if self.mode == "reset":
                    # |old + th w| = f_max / k_e: the positive root of a quadratic in th
                    o, ww = old[over], w[over]
                    a = (ww * ww).sum(axis=1)
                    b = (o * ww).sum(axis=1)
                    c = (o * o).sum(axis=1) - (self.f_max / self.k_e) ** 2
                    th = np.clip((-b + np.sqrt(np.maximum(b * b - a * c, 0.0))) / a, 0.0, 1.0)
                    s.dr[over] = (1.0 - th)[:, None] * ww
                elif self.mode == "reset/step":
                    s.dr[over] = 0.0
                else:
                    norm = np.sqrt((s.dr[over] ** 2).sum(axis=1))
                    s.dr[over] *= (self.f_max / (self.k_e * norm))[:, None]
                if self.mode != "coulomb":
                    s.overshoot += int((self.k_e * np.sqrt((s.dr[over] ** 2).sum(axis=1))
                                        > self.f_max).sum())
                # the energy a break takes out of the contact: reset, the contact's energy
                # where it broke (f_max^2 / 2 k_e once located in the step; the whole of
                # dr's at the end of the step for reset/step); coulomb, the energy above the
                # threshold that the rescaling removes (the sliding work)
                if self.mode == "reset":
                    lost = 0.5 * self.k_e * ((o + th[:, None] * ww) ** 2).sum()
                else:
                    lost = before - 0.5 * self.k_e * (s.dr[over] ** 2).sum()
                s.diss_break += float(lost)
            f -= self.k_e * s.dr
        s.f_damp = np.zeros_like(s.x)
        if self.gamma:
            if self.damping == "implicit":
                # -m gamma v(t+dt), with v(t+dt) = v + dt/(2m) (F_other - m gamma v(t+dt))
                h = 0.5 * self.dt / self.mass
                s.f_damp = -self.mass * self.gamma * (v + h * (f + f_other)) \
                    / (1 + 0.5 * self.gamma * self.dt)
            else:
                s.f_damp = -self.mass * self.gamma * v
            f += s.f_damp
        return f

    # energy ---------------------------------------------------------------------------
    def drive_force_x(self, s: ReferenceState) -> float:
        """The drive springs' total x force on the particles, which the plate's anchors feel
        with the opposite sign: the plate's power is V_d times it."""
        if self.k_d is None:
            return 0.0
        return float((self.k_d * (s.anchor[:, 0] + self.V_d * s.t - s.x[:, 0])).sum())

    def ledger(self, s: ReferenceState) -> Ledger:
        drive = 0.0
        if self.k_d is not None:
            u = s.x - s.anchor - np.array([self.V_d * s.t, 0.0])
            drive = 0.5 * float((self.k_d * (u * u).sum(axis=1)).sum())
        contact = 0.0 if self.k_e is None else 0.5 * self.k_e * float((s.dr ** 2).sum())
        return Ledger(bond=float(self.bond_energy(s.x)), drive=drive, contact=contact,
                      kinetic=0.5 * self.mass * float((s.v ** 2).sum()),
                      work_plate=s.work_plate, diss_break=s.diss_break, diss_damp=s.diss_damp)

    # integration ----------------------------------------------------------------------
    def start(self, x, v=None, anchor=None, dr=None) -> ReferenceState:
        """Initial state; the bond images are fixed here, from the lattice ``anchor`` (default
        ``x``), which must have every bond shorter than half the box. ``dr`` (N, 2): the
        contacts' initial displacements (docs/model.md's random start; default 0, synchronized)."""
        x = np.array(x, dtype=float)
        lattice = x if anchor is None else np.asarray(anchor, float)
        d0 = lattice[self.bonds[:, 0]] - lattice[self.bonds[:, 1]]
        self.shift = -self.L * np.round(d0 / self.L)
        x = np.array(x, dtype=float)
        s = ReferenceState(x=x, v=np.zeros_like(x) if v is None else np.array(v, float),
                           dr=np.zeros_like(x) if dr is None else np.array(dr, float),
                           anchor=x.copy() if anchor is None else
                           np.array(anchor, float))
        fb = self.bond_forces(s.x)
        s.f = fb + self.substrate_forces(s, s.v, advance=False, f_other=fb)
        return s

    def step(self, s: ReferenceState, n: int = 1) -> ReferenceState:
        h = 0.5 * self.dt / self.mass
        for _ in range(n):
            # the ledger's step terms: the plate's work by the trapezoid rule over the step,
            # V_d dt (F_n + F_n+1)/2, and the damping's what the two half kicks take from the
            # kinetic energy through the damping force, -dt/4 (fd_n . (v_n + vh) + fd_n+1 .
            # (vh + v_n+1)) (the work of that force over each kick, exactly)
            p0, v0, fd0 = self.drive_force_x(s), s.v, s.f_damp
            s.v = s.v + h * s.f
            vh = s.v
            s.x = s.x + self.dt * s.v
            s.t += self.dt
            fb = self.bond_forces(s.x)
            s.f = fb + self.substrate_forces(s, s.v, advance=True, f_other=fb)
            s.v = s.v + h * s.f
            s.work_plate += 0.5 * self.dt * self.V_d * (p0 + self.drive_force_x(s))
            s.diss_damp -= 0.25 * self.dt * float((fd0 * (v0 + vh)).sum()
                                                   + (s.f_damp * (vh + s.v)).sum())
        return s


def step_watching_the_box(ref: Reference, s: ReferenceState, n: int, every: int = 50):
    """``ref.step(s, n)`` in pieces of ``every`` steps; (the state, whether some atom stood
    outside the box [0, L) after some piece): a window that crossed the periodic boundary,
    even if the atom came back by its end."""
    crossed = False
    done = 0
    while done < n:
        k = min(every, n - done)
        ref.step(s, k)
        done += k
        crossed = crossed or bool(np.any((s.x < 0) | (s.x >= ref.L)))
    return s, crossed


def phase_statistics(dr, k_e, f_max) -> dict:
    """The contacts' load-phase statistics of docs/model.md ("Contact phase") from their
    displacements ``dr`` (N, 2): u_i = k_e |dr_i| / f_max, Z = <exp(2 pi i u)>, R = |Z|, R2 the
    modulus of the second harmonic <exp(4 pi i u)>, and the mean and (population) standard
    deviation of u."""
    u = k_e * np.sqrt((np.asarray(dr, float) ** 2).sum(axis=1)) / f_max
    z, z2 = np.exp(2j * np.pi * u).mean(), np.exp(4j * np.pi * u).mean()
    return {"R": abs(z), "Z_re": z.real, "Z_im": z.imag, "R2": abs(z2), "u_mean": u.mean(),
            "u_std": u.std()}


#: the accuracy presets' time-step constants as docs/model.md ("Integration") states them:
#: (c_contact, c_stable) of dt = min(c_contact / omega_c, c_stable / omega_max)
TIME_STEP_RULE = {"fast": (0.2, 1.8), "default": (0.1, 1.5), "precise": (0.05, 1.0)}


def time_step(preset: str, k_b: float, k_e: float, k_d: float, dk_d: float,
              mass: float = 1.0) -> float:
    """docs/model.md's time step of a preset, written from its text: the contacts' load cycle
    (a particle on its contact spring and its stiffest drive spring, sqrt((k_e + k_d + dk_d)
    / m)) resolved to c_contact, and no more than c_stable over the fastest mode (its four bonds
    too, sqrt((4 k_b + k_e + k_d + dk_d) / m))."""
    c_contact, c_stable = TIME_STEP_RULE[preset]
    contact = np.sqrt((k_e + k_d + dk_d) / mass)
    fastest = np.sqrt((4 * k_b + k_e + k_d + dk_d) / mass)
    return float(min(c_contact / contact, c_stable / fastest))
