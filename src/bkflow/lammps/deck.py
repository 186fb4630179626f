"""LAMMPS data file and input deck of one run, as pure text (docs/model.md, "Forces on particle i").

Nothing here runs LAMMPS or touches the disk: ``data_text`` and ``deck_text`` return
strings that ``bkflow.lammps.deckfiles.write_deck`` saves, that the engine feeds to the LAMMPS
Python API, and that run standalone with ``lmp -in in.bk`` (the wheel's ``lmp`` auto-loads the
bkflow plugin through the ``lammps.plugins`` entry point).

The forces of docs/model.md are all applied by ``fix bk/substrate`` (plugins/README.md): bonds,
drive, friction and damping in one pass. The bond topology comes from the data file with no
bond style (LAMMPS keeps the network, builds no bond lists, computes nothing); the fix evaluates the
bonds itself because ``bond_style harmonic`` takes the minimum image of each bond, which jumps
to another periodic image once a soft layer stretches a bond past half the box (it does at
phi = 0.1 on the paper's 20x5 lattice), while docs/model.md's network never changes. The per-atom
drive stiffness k_d^i is the custom property ``d_kd``, read from the data file section
``DriveStiffness``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from bkflow import __version__
from bkflow.model.lattice import Lattice, contact_start, lattice_for
from bkflow.model.params import PATHS, S_X, RunSpec
from bkflow.store.layout import (
    BLOCKS,
    CLUSTER_ROWS,
    DATA,
    EXTREMA,
    FRONTS,
    PSI_RECORD,
    SERIES_PHASE,
    SERIES_STRESS,
    SLIP_ROWS,
    SLIPS,
    SNAPSHOTS,
)

#: fix ID of the substrate (fix bk/substrate)
SUBSTRATE_FIX = "bk"
#: the slots of fix bk/substrate's global vector, 0-based (f_bk[slot + 1] in a deck): the
#: plugin names them in plugins/bk_interface.h (enum bk_slot), tests/plugins/test_interface.py
#: checks that the two agree
SLOTS = {"sigma_x": 0, "breaks_step": 1, "breaks_total": 2, "plate": 3, "bond_max": 4,
         "path": 5, "e_bond": 6, "e_drive": 7, "e_contact": 8, "e_kinetic": 9, "work": 10,
         "diss_break": 11, "diss_damp": 12, "image_base": 13,
         "overshoot": 14}
#: fix ID of fix bk/slips (scenes clusters, full); its vector is [events, events written]
SLIPS_FIX = "slips"
#: fix ID of fix bk/fronts (scenes fronts, full); its vector is [events, events written]
FRONTS_FIX = "fronts"


@dataclass(frozen=True)
class DeckOptions:
    """How a deck is written, checked once and passed whole: the integration ``path`` (one of
    ``bkflow.model.params.PATHS``), the LAMMPS settings that speed it up (``fast``: the
    FAST_SETTINGS; None: with every path but ``general``), the files it names (relative for
    a standalone deck; None: not written), the thermo interval (None: 1% of the run), and,
    for tests, which parts of the model's forces it applies."""

    path: str = "auto"
    fast: bool | None = None
    data: str = DATA
    #: fix bk/reduce's records (None: no fix bk/reduce; extrema None: the blocks only, what a
    #: companion run keeps)
    extrema: str | None = EXTREMA
    blocks: str | None = BLOCKS
    stress: str | None = SERIES_STRESS
    phase: str | None = SERIES_PHASE
    psi: str | None = PSI_RECORD
    slip_rows: str = SLIP_ROWS
    cluster_rows: str = CLUSTER_ROWS
    snapshots: str = SNAPSHOTS
    slips: str = SLIPS
    fronts: str = FRONTS
    thermo_every: int | None = None
    drive: bool = True
    contact: bool = True
    damp: bool = True
    #: keep the energy ledger (``energy``): None, when the scene needs it (RunSpec.writes_energy)
    energy: bool | None = None
    #: continue a run from its restart file at this step (None: a new run): every output is
    #: appended to, the step sampled already left out (``append`` of the output fixes, a
    #: dump's ``delay``)
    append_from: int | None = None

    def __post_init__(self):
        if self.path not in PATHS:
            raise ValueError(f"path must be one of {', '.join(PATHS)}, got {self.path!r}")
        if self.fast is None:
            object.__setattr__(self, "fast", self.path != "general")

    def replace(self, **changes) -> DeckOptions:
        return dataclasses.replace(self, **changes)


def _f(x: float) -> str:
    """Shortest text that reads back as the same double (-0.0 written as 0.0)."""
    return repr(float(x) + 0.0)


def data_text(spec: RunSpec, lattice: Lattice | None = None, velocities=None) -> str:
    """LAMMPS data file (atom_style bond) with the lattice, its bonds, k_d^i and, for the
    random start, the contacts' initial displacements (section ``ContactStart``).

    ``lattice`` replaces the run's lattice (positions must lie in the box); ``velocities``
    (N, 2) adds a Velocities section (default: all particles at rest, as in docs/model.md).
    """
    lat = lattice if lattice is not None else lattice_for(spec)
    n, nb = len(lat.positions), len(lat.bonds)
    lines = [
        f"bkflow {__version__} lattice {spec.Lx}x{spec.Ly} phi={_f(spec.phi)} seed={spec.seed}",
        "",
        f"{n} atoms",
        f"{nb} bonds",
        "1 atom types",
        "1 bond types",
        "",
        f"0.0 {_f(lat.Lx)} xlo xhi",
        f"0.0 {_f(lat.Ly)} ylo yhi",
        "-0.5 0.5 zlo zhi",
        "",
        "Masses",
        "",
        f"1 {_f(spec.mass)}",
        "",
        "Atoms # bond",
        "",
    ]
    lines += [f"{i + 1} 1 1 {_f(x)} {_f(y)} 0.0" for i, (x, y) in enumerate(lat.positions)]
    if velocities is not None:
        lines += ["", "Velocities", ""]
        lines += [f"{i + 1} {_f(vx)} {_f(vy)} 0.0" for i, (vx, vy) in enumerate(velocities)]
    lines += ["", "Bonds", ""]
    lines += [f"{k + 1} 1 {a + 1} {b + 1}" for k, (a, b) in enumerate(lat.bonds)]
    lines += ["", "DriveStiffness", ""]
    lines += [f"{i + 1} {_f(k)}" for i, k in enumerate(lat.k_d)]
    if spec.start != "synchronized":
        lines += ["", "ContactStart", ""]
        lines += [f"{i + 1} {_f(u)}" for i, u in enumerate(contact_start(spec))]
    return "\n".join(lines) + "\n"


def substrate_fix(spec: RunSpec, drive: bool = True, contact: bool = True,
                  damp: bool = True, path: str = "general", energy: bool = False) -> str:
    """The ``fix bk/substrate`` line of a run: the bonds, and the parts asked for; with path
    ``auto`` or ``fused`` the fix integrates by itself (``PATHS``, plugins/README.md); with
    ``energy`` it keeps the energy ledger's running sums."""
    parts = [f"bonds {_f(spec.k_b)} 1.0"]
    if drive:
        parts.append(f"drive {_f(spec.V_d)} d_kd")
    if contact:
        parts.append(f"friction {_f(spec.k_e)} {_f(spec.mu_s)} {_f(spec.sigma_n)} "
                     f"{_f(spec.area)} {spec.contact_rule}")
    if damp:
        parts.append(f"damp {_f(spec.gamma)} {spec.damping}")
    if contact and spec.start != "synchronized":
        parts.append("start d_dr0")
    if energy:
        parts.append("energy")
    if path == "fused":
        parts.append("fused")
    elif path == "auto":
        parts.append("integrate")
    return f"fix             {SUBSTRATE_FIX} all bk/substrate " + " ".join(parts)


def _length(spec: RunSpec, steps: int | None) -> str:
    """The header's line on the run's length: the steps the deck runs (``steps``, default the
    whole run), which an adaptive run that stopped by its rule ends short of its cap t_end."""
    if steps is None or steps == spec.n_steps:
        return f"# t_end = {spec.t_end:g} ({spec.n_steps} steps)"
    return (f"# t = {steps * spec.dt:g} ({steps} steps): the adaptive run stopped there by its "
            f"rule, of at most t_end = {spec.t_end:g} ({spec.n_steps} steps)")


def _header(spec: RunSpec, path: str, steps: int | None = None) -> list[str]:
    return [
        f"# bkflow {__version__}: 2D Burridge-Knopoff layer (Giacco et al. 2014; docs/model.md)",
        f"# phi = {spec.phi:g} (k_b = {spec.k_b:g}), lattice {spec.Lx}x{spec.Ly}, "
        f"seed {spec.seed}, contact rule {spec.contact_rule}, {spec.start} start",
        f"# dt = {spec.dt:.6g}, {spec.dt_rule}",
        _length(spec, steps),
        "# Needs fix bk/substrate: the lmp of the environment where bkflow is installed loads it",
        "# by itself; any other LAMMPS 22Jul2025 build needs `plugin load .../bkflowplugin.so`.",
    ] + ({
        "auto": ["# `integrate`: fix bk/substrate integrates the layer itself, on the fused path",
                 "# on any number of ranks (lmp -in, or mpirun -np K lmp -in with K up to the",
                 "# number of lattice rows: each rank holds a block of rows), one rank's",
                 "# trajectory to the bit."],
        "fused": ["# `fused`: the fused path (any number of ranks up to the number of rows)."],
        "general": ["# fix nve + fix bk/substrate + fix enforce2d: the general path, any number of",
                    "# ranks."],
    }[path]) + [""]


#: LAMMPS settings that speed up the fused path and change no number (benchmarks/measure/floor.py):
#: the fused fix mirrors positions into LAMMPS only when something reads them, so a
#: neighbour check every step would force a copy every step. On several ranks on the general
#: path they are safe too: ghosts reach bond_limit + 1 beyond a subdomain, and an atom moves
#: far less than that in 50 steps; the fix reads no ghost force, so newton_pair off (no
#: reverse communication) changes nothing. (The fused path on several ranks needs no ghost.)
FAST_SETTINGS = ("timer           loop", "neigh_modify    every 50 delay 0 check yes",
                 "newton          off off")


#: the ranks in one column, each holding a block of lattice rows: what the fused path needs on
#: several ranks (plugins/README.md "The fused path"); the general path's decks leave the grid
#: to LAMMPS, which cuts a wide lattice across x (fewer ghost atoms for its cutoff)
PROCESSORS = "processors      1 * 1"


def _system(spec: RunSpec, files: DeckOptions, fast: bool = False) -> list[str]:
    return [
        "units           lj",
        "dimension       2",
        "boundary        p p p",
        "atom_style      bond",
        "atom_modify     map array",
    ] + ([PROCESSORS] if files.path != "general" else []) + (
        [FAST_SETTINGS[0]] if fast else []) + [
        # every atom holds all four of its bonds: the fix sums them without reverse comm
        FAST_SETTINGS[2] if fast else "newton          on off",
        "fix             kd all property/atom d_kd",
    ] + ([
        # the random start: each contact's initial displacement, taken by fix bk/substrate
        "fix             dr0 all property/atom d_dr0",
        f"read_data       {files.data} fix kd NULL DriveStiffness fix dr0 NULL ContactStart",
    ] if spec.start != "synchronized" else [
        f"read_data       {files.data} fix kd NULL DriveStiffness",
    ])


#: ghost cutoff for one rank, where every bond partner is a local atom
SERIAL_COMM_CUTOFF = 0.1


def _dynamics(spec: RunSpec, drive: bool, contact: bool, damp: bool, path: str = "general",
              fast: bool = False, energy: bool = False) -> list[str]:
    lines = [
        # on several ranks a bond partner is found only as a ghost within this cutoff, so the
        # default covers the longest bond the run allows; one rank can pass -var comm_cutoff 1
        f"variable        comm_cutoff index {_f(spec.bond_limit + 1.0)}",
        "comm_modify     cutoff ${comm_cutoff}",
        "neighbor        0.5 bin",
        FAST_SETTINGS[1] if fast else "neigh_modify    every 1 delay 0 check yes",
        f"timestep        {_f(spec.dt)}",
        "",
    ]
    if path != "general":  # the fix does the velocity-Verlet step, in 2D, by itself
        lines += [substrate_fix(spec, drive, contact, damp, path, energy), ""]
    else:
        lines += ["fix             nve all nve",
                  substrate_fix(spec, drive, contact, damp, energy=energy),
                  "fix             2d all enforce2d", ""]
    return lines


def _outputs(spec: RunSpec, files: DeckOptions, thermo_every: int | None,
             contact: bool = True) -> list[str]:
    """The outputs of the run's scene, and nothing else: the records its scene keeps
    (``bkflow.model.scenes.SCENE_RECORDS``), each written by

    (every scene) ``fix bk/reduce``: sigma_x sampled every stress_nevery steps and the
                 contacts' phase statistics every phase_nevery steps, reduced in the run to
                 what the analysis reads (``extrema.npy``: sigma_x's turning points at the
                 smallest threshold any analysis asks for; ``blocks.npy``: sums over blocks of
                 block_nevery steps; bkflow.observables.reduced), no per-atom output at all;
                 the steady-state verdict reads these two.
    series:      the raw series, binary: sigma_x every stress_nevery steps (``stress.npy``)
                 and the phase statistics every phase_nevery steps (``phase.npy``), with the
                 ledger where the scene keeps energy.
    snapshots:   ``fix bk/psi``: Psi(t) computed in the run every snapshot_nevery steps
                 (``psi.npy``), for its late-time plateau.
    slips:       ``fix bk/slips``: it follows sigma_x on the very samples of the records and
                 keeps in memory a copy of the positions at the running maximum and minimum.
                 Without slip_frames it computes each slip's row of the catalogue and its
                 clusters from the two frames in the run (``catalogue``: ``slips.npy``,
                 ``clusters.npy``) and writes no frames.
    slip_frames: the two frames of each slip (maximum, following minimum) written once the
                 slip is confirmed (``slips.lammpstrj``), two frames per slip after the
                 transient rather than every step. The same zigzag rule finds the events again
                 in the records (bkflow.observables.reduced), which is how each pair is matched
                 to its event.
    energy:      the energy ledger (fix bk/substrate ``energy``; the records get the breaks
                 and the ledger at every extremum and block end) and each contact's first
                 break in every slip (fix bk/slips ``breaks``): what the event catalogue
                 needs (``events.parquet``; bkflow.observables.catalogue).
    fronts:      ``fix bk/fronts`` (``fronts.bin``): the x velocity of every particle at every
                 sample from each slip's maximum to its minimum (float32, binary), to follow
                 rupture fronts; only one event is held in memory (the full scene: the first
                 FRONTS_IN_FULL slips only).
    frames:      whole position frames every snapshot_nevery steps (``snapshots.lammpstrj``,
                 for OVITO and the like).
    """
    more = " append" if files.append_from is not None else ""
    parts = (_reduce_fix(spec, files, contact, more), _stress_fix(spec, files, more),
             _phase_fix(spec, files, contact, more), _psi_fix(spec, files, more),
             _snapshot_dump(spec, files), _slips_fix(spec, files, more),
             _fronts_fix(spec, files, more), _thermo(spec, thermo_every))
    return [line for part in parts for line in part]


def _reduce_fix(spec: RunSpec, files: DeckOptions, contact: bool, more: str) -> list[str]:
    """What the analysis reads of sigma_x and the phases, reduced in the run (every scene)."""
    if not files.blocks:
        return []
    return [f"fix             reduce all bk/reduce {spec.stress_nevery} {SUBSTRATE_FIX} "
            f"threshold {_f(spec.extrema_threshold_stress)} block {spec.block_nevery} "
            f"extrema {files.extrema or 'none'} blocks {files.blocks}"
            + (f" phase {spec.phase_nevery}" if contact else "")
            + (" energy" if _energy(spec, files) else "") + more]


def _stress_fix(spec: RunSpec, files: DeckOptions, more: str) -> list[str]:
    """The raw sigma_x series, buffered by the plugin (fix print would write and flush every
    line)."""
    if not (files.stress and spec.writes_series):
        return []
    return [f"fix             stress all bk/stress {spec.stress_nevery} {SUBSTRATE_FIX} "
            f"file {files.stress}" + (" energy" if _energy(spec, files) else "") + more]


def _phase_fix(spec: RunSpec, files: DeckOptions, contact: bool, more: str) -> list[str]:
    """The contacts' load phases: what the steady-state verdict reads."""
    if not (files.phase and contact and spec.writes_series):
        return []
    return [f"fix             phase all bk/phase {spec.phase_nevery} {SUBSTRATE_FIX} "
            f"file {files.phase}{more}"]


def _psi_fix(spec: RunSpec, files: DeckOptions, more: str) -> list[str]:
    """Psi(t), computed in the run from the positions every snapshot_nevery steps."""
    if not (spec.writes_snapshots and files.psi):
        return []
    return [f"fix             psi all bk/psi {spec.snapshot_nevery} {spec.Lx} {spec.Ly} "
            f"file {files.psi}{more}"]


def _snapshot_dump(spec: RunSpec, files: DeckOptions) -> list[str]:
    """Whole position frames every snapshot_nevery steps (scene full)."""
    if not (spec.writes_frames and files.snapshots):
        return []
    return [
        f"dump            snap all custom {spec.snapshot_nevery} {files.snapshots} "
        "id type x y z ix iy iz",
        'dump_modify     snap sort id format float %.9g',
    ] + ([f"dump_modify     snap append yes delay {files.append_from + 1}"]
         if files.append_from is not None else [])


def _slips_fix(spec: RunSpec, files: DeckOptions, more: str) -> list[str]:
    """Each slip's two frames (scenes clusters, events, full), or its row of the catalogue
    and its clusters computed in the run (scene figures)."""
    if not (spec.writes_slips and files.slips):
        return []
    frames = files.slips if spec.writes_slip_frames else "none"
    rows = "" if spec.writes_slip_frames else (
        f" catalogue {files.slip_rows} {files.cluster_rows} sx {_f(S_X)} kb {_f(spec.k_b)} "
        f"lattice {spec.Lx} {spec.Ly}")
    return [f"fix             {SLIPS_FIX} all bk/slips {spec.stress_nevery} {SUBSTRATE_FIX} "
            f"{_f(spec.slip_threshold_stress)} file {frames} start {spec.slips_start_step}"
            + rows + (" breaks" if spec.writes_energy else "") + more]


def _fronts_fix(spec: RunSpec, files: DeckOptions, more: str) -> list[str]:
    """Every particle's x velocity through each slip (scenes fronts, full)."""
    if not (spec.writes_fronts and files.fronts):
        return []
    limit = "" if spec.fronts_limit is None else f" limit {spec.fronts_limit}"
    return [f"fix             {FRONTS_FIX} all bk/fronts {spec.stress_nevery} {SUBSTRATE_FIX} "
            f"{_f(spec.slip_threshold_stress)} file {files.fronts} start "
            f"{spec.slips_start_step}{limit}{more}"]


def _thermo(spec: RunSpec, thermo_every: int | None) -> list[str]:
    """The thermo lines: sigma_x, the breaks and the longest bond, every 1% of the run unless
    ``thermo_every``."""
    thermo = thermo_every or max(1, spec.n_steps // 100)
    cols = "".join(f"f_{SUBSTRATE_FIX}[{SLOTS[k] + 1}] "
                   for k in ("sigma_x", "breaks_step", "breaks_total", "bond_max"))
    return [
        f"thermo          {thermo}",
        f"thermo_style    custom step time {cols}cpuremain",
        "thermo_modify   lost error norm no flush yes",
        "",
    ]


def _energy(spec: RunSpec, o: DeckOptions) -> bool:
    return spec.writes_energy if o.energy is None else o.energy


def setup_text(spec: RunSpec, options: DeckOptions = DeckOptions(),
               steps: int | None = None) -> str:
    """Everything of the deck before ``run``: system, forces, integrator, outputs; its header
    gives the length of a run of ``steps`` steps (default: the whole run). Neither
    the path nor the fast settings change a number beyond rounding (the fused path sums in
    another order; tests/plugins/test_fused.py)."""
    o = options
    lines = (_header(spec, o.path, steps) + _system(spec, o, o.fast)
             + _dynamics(spec, o.drive, o.contact, o.damp, o.path, o.fast, _energy(spec, o))
             + _outputs(spec, o, o.thermo_every, o.contact))
    return "\n".join(lines)


def continue_text(spec: RunSpec, restart: str,
                  options: DeckOptions = DeckOptions(data="")) -> str:
    """Deck lines that continue a run from a LAMMPS restart file (``write_restart``).

    The substrate fix is re-specified with the same ID, so its contact history, anchors and
    clock come back from the restart file (on any path); k_d^i come back with ``fix kd``.
    """
    o = options
    props = ["fix             kd all property/atom d_kd"] + (
        ["fix             dr0 all property/atom d_dr0"] if spec.start != "synchronized" else [])
    lines = (_header(spec, o.path) + ([PROCESSORS] if o.path != "general" else [])
             + [f"read_restart    {restart}"] + ([FAST_SETTINGS[0]] if o.fast else []) + props
             + _dynamics(spec, True, True, True, o.path, o.fast, _energy(spec, o))
             + _outputs(spec, o, o.thermo_every))
    return "\n".join(lines)


def deck_text(spec: RunSpec, options: DeckOptions = DeckOptions(),
              steps: int | None = None) -> str:
    """The complete standalone deck: ``setup_text`` plus the run of ``steps`` steps (default:
    the whole run, ``spec.n_steps``; fewer: an adaptive run that stopped by its rule, whose
    deck redoes the steps it ran), the header giving the same count as the ``run`` line."""
    n = spec.n_steps if steps is None else steps
    return setup_text(spec, options.replace(), n) + f"run             {n}\n"
