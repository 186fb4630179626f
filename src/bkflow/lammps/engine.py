"""Run one deck through the LAMMPS Python API, in chunks, with guards and a completion record.

``run`` is a few named steps: claim the run directory (``bkflow.store.rundir``: its lock, a
finished run refused unless a longer request continues it from its restart file, a partial
one cleared), write the deck, advance LAMMPS chunk by chunk with the guards and the progress
line, and commit meta.json. Between chunks the engine checks for the ways a run goes wrong
(NaN, lost atoms, a torn bond, a step that carries contacts past their whole range) and
stops with a ``RunError`` naming phi, the step and the cause. An adaptive run
(RunSpec.target_error, RunSpec.until_steady) stops when the error of mu_bar is below its
target and/or the run is steady, or names the states it visited (``AdaptiveStop``, on
the run's records, ``bkflow.observables.reduced``, and ``bkflow.observables.states.window``).
"""

from __future__ import annotations

import contextlib
import copy
import math
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bkflow import __version__
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
from bkflow.lammps.plugin import (
    ERROR_TOKENS,
    PATH_CODES,
    block_rows,
    build_info,
    lammps_version,
    open_lammps,
)
from bkflow.model.params import (
    ADAPTIVE_CHUNK_T,
    ADAPTIVE_T_MIN,
    STEADY_AGREEMENT,
    STEADY_DRIFT_BOUND,
    STEADY_T_MIN,
    RunSpec,
    transient_step,
)
from bkflow.observables import states
from bkflow.observables.stationarity import mean_error
from bkflow.observables.stress import Zigzag
from bkflow.store.formats import write_text_atomic
from bkflow.store.provenance import record as provenance
from bkflow.store.rundir import COMPANION, DATA, DECK, LOG, META, RESTART, RunDir


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


#: a run stops when more than this share of its contact breaks (at least of
#: OVERSHOOT_MIN_BREAKS) left the contact past its threshold: steps too long for the friction
#: law (phi = 10, 2000 time units: none at the default preset; 2e-3 at dt omega_max = 1.9; a
#: contact 100 times stiffer, k_e = 1000, 5e-4 at the default preset and 79% at 1.9)
OVERSHOOT_ALLOWED = 0.01
OVERSHOOT_MIN_BREAKS = 1000

#: a layer that tears at a time step this far inside the stability bound (dt omega_max <=
#: 0.5) tears because of its physics, not of dt
TEAR_IS_PHYSICAL_BELOW_C = 0.5


class AdaptiveStop:
    """The stop rule of an adaptive run (RunSpec.adaptive), checked between chunks once the
    run is long enough (ADAPTIVE_T_MIN; STEADY_T_MIN for a run until steady), over the
    analysed window of the run so far (the transient rule of a fixed run of that length):

    - ``target_error``: mu_bar's standard error is below the target and reliable, the error
      that covers the layer's switching between states (``bkflow.observables.states``);
    - ``until_steady``: the window is ``steady`` (``bkflow.observables.states.window``: no memory of
    the
      start shown, no switching between states that the window has not averaged over, the
      stress trend-free), and the trend test excludes a drift above STEADY_DRIFT_BOUND.

    The run's records (fix bk/reduce: the extrema and the block sums,
    ``bkflow.observables.reduced``) are read at every check, as the summary reads them: the summary
    of the finished run finds the very same slips, error, trend and state. What the last check found
    is ``last`` (a ``bkflow.observables.states.Window``); ``record`` returns it as data, and
    ``bkflow.cli.report`` words it."""

    def __init__(self, spec: RunSpec, run_dir: RunDir):
        self.spec, self.rd = spec, run_dir
        self.fail = np.array([])    # sigma_fail of the slips so far
        self.t_fail = np.array([])
        # the slips at the run's threshold, found once: the final extrema fed as they come
        # (the last record, the extremum under way, is fed to a copy at each check)
        self.zigzag = Zigzag(spec.slip_threshold_stress)
        self.fed, self.maxima = 0, []
        self.met, self.checks = False, 0
        self.last: states.Window | None = None
        self.last_error = None      # mu_bar's error at the last check (covering the switching)
        self.own_error = None       # ... the run's own (the states' means it visited)
        self.companion_gap = None   # the pair's gap at the last check (the main run's rule)
        self.pair_disagrees = False

    @property
    def last_mean(self) -> float:
        return self.last.mean if self.last is not None else math.nan

    def error(self, t_transient: float):
        """mu_bar's own error over the slips after ``t_transient`` found so far."""
        return mean_error(self.fail[self.t_fail >= t_transient] / self.spec.sigma_n)

    def reached(self, step: int) -> bool:
        spec = self.spec
        t_min = STEADY_T_MIN if spec.until_steady else ADAPTIVE_T_MIN
        if step * spec.dt < min(t_min, spec.t_end):
            return False
        self.checks += 1
        red = self.rd.read_reduced(spec)
        if red.has_extrema and len(red.extrema):
            s = np.asarray(red.extrema["sigma"], float)
            final = len(s) - 1
            self.maxima += self.zigzag.feed(s[self.fed:final].tolist())[0]
            self.fed = final
            pending = copy.copy(self.zigzag).feed([s[final]])[0]
            at = np.asarray(self.maxima + pending, np.int64)
            self.fail = s[at]
            self.t_fail = red.sample_index()[at] * spec.stress_nevery * spec.dt
        t, sigma, phase = red.series()
        t0 = transient_step(spec.transient, step) * spec.dt
        self.last = win = states.window(spec, t, sigma, phase if spec.until_steady else None,
                                        t0, own_error=False, weights=red.weights())
        met = True
        switching = spec.until_steady and win.state in states.SWITCHING
        if spec.target_error is not None:
            est = self.error(t0)
            if est.n < 2:
                return False
            self.last_error = win.err_of("mu_bar", est.mean, est.error, spec.phi, spec.N)
            self.own_error = est.error
            # a layer that switches between states: what a run can give is the mean of the
            # states it visits (their own error), not the long-run mean, whose error falls
            # only as the switching is averaged over (states.needed_length; reported)
            err = est.error if switching else self.last_error
            met &= bool(est.reliable and err <= spec.target_error)
        if spec.until_steady:
            met &= bool(switching or (win.state == "steady"
                                      and win.trend.drift_bound <= STEADY_DRIFT_BOUND))
        self.met = met
        return met

    def record(self, requested: RunSpec, t_run: float, stopped_early: bool) -> dict:
        """What the stop rule found, as data (``bkflow.cli.report.stop_line`` words it)."""
        w = self.last
        trend = None if w is None else w.trend
        comp = None if w is None else w.comp
        needed = None
        if requested.target_error is not None and self.last_error is not None:
            needed = states.needed_length(requested, self.error(0.0).mean
                                          if len(self.fail) else math.nan)
        return {"target_error": requested.target_error,
                "until_steady": requested.until_steady,
                "drift_bound_required": STEADY_DRIFT_BOUND if requested.until_steady else None,
                "agreement_required": STEADY_AGREEMENT if requested.companion else None,
                "t_cap": requested.t_end, "t_run": t_run,
                "reached": bool(stopped_early or self.met),
                "mu_bar_err_at_stop": self.last_error,
                "mu_bar_own_err_at_stop": self.own_error,
                "state_at_stop": None if w is None else w.state,
                "states_visited_at_stop": None if comp is None else comp.name,
                "drift_at_stop": None if trend is None else trend.drift,
                "drift_err_at_stop": None if trend is None else trend.drift_err,
                "drift_z_at_stop": None if trend is None else trend.drift_z,
                "drift_bound_at_stop": None if trend is None else trend.drift_bound,
                "phase_fluctuation_at_stop": None if w is None or w.contacts is None
                else w.contacts.fluctuation,
                "memory_chi": states.memory_chi(requested.N),
                "companion_gap_at_stop": self.companion_gap,
                "pair_disagrees_at_stop": self.pair_disagrees,
                "switching_calibrated": None if w is None else w.calibration is None,
                "t_needed": needed,
                "checks": self.checks}


def in_notebook() -> bool:
    """Whether this process is a Jupyter kernel (where stderr is no terminal, yet a progress
    bar is wanted)."""
    shell = sys.modules.get("IPython")
    try:
        return shell is not None and type(shell.get_ipython()).__name__ == "ZMQInteractiveShell"
    except Exception:  # an IPython without a running shell
        return False


class _Progress:
    """A progress bar of the run (steps, sigma_x, ETA) through ``tqdm.auto``: a line on a
    terminal (stderr), a widget in a notebook; silent anywhere else (a pipe, a sweep's
    worker) unless asked for."""

    def __init__(self, label: str, total: int, enabled: bool | None = None):
        if enabled is None:
            enabled = sys.stderr.isatty() or in_notebook()
        self.bar = None
        if enabled:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total, desc=label, unit="step", unit_scale=True,
                            file=sys.stderr, smoothing=0.1, mininterval=0.5)

    def update(self, step: int, sigma_x: float) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(f"sigma_x {sigma_x:+.4f}", refresh=False)
            self.bar.update(step - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


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


def _claim(rd: RunDir, overwrite: bool) -> None:
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
        raise RunExistsError(f"{rd.path} already holds a finished run ({META}); choose "
                             "another output directory, or replace it (--overwrite; "
                             "overwrite=True from Python)")
    why = rd.foreign()
    if why is not None:
        raise RunExistsError(f"{rd.path} {why}: bkflow writes only into an empty directory or "
                             "its own run; choose another --out")
    rd.clear()
    rd.mark()


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
        self.adaptive = AdaptiveStop(spec, rd) if spec.adaptive else None

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


def _stop(legs: list[_Leg], step: int) -> bool:
    """The stop rule of an adaptive run at ``step``: its own (AdaptiveStop), and with a
    companion, the companion's too and the agreement of their mean stresses (within
    STEADY_AGREEMENT, or their errors: ``bkflow.observables.states.pair_disagrees``)."""
    if len(legs) == 1 or legs[1].adaptive is None:
        # alone, or beside a companion with no rule of its own (a fixed-length protocol's run
        # with only an error target): the run's own rule decides
        return legs[0].adaptive.reached(step)
    reached = [leg.adaptive.reached(step) for leg in legs]  # every leg reads its new samples
    main, comp = legs[0].adaptive, legs[1].adaptive
    if main.last is None or comp.last is None:
        return False
    main.companion_gap = main.last_mean / comp.last_mean - 1 if comp.last_mean else math.nan
    main.pair_disagrees = states.pair_disagrees(main.last, comp.last, STEADY_AGREEMENT)
    ok = all(reached) and not main.pair_disagrees
    main.met = ok
    return ok


def _advance(legs: list[_Leg], chunk: int, bar: _Progress, start: int = 0) -> int:
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
        if legs[0].adaptive is not None and _stop(legs, step):
            break
    return step


#: an adaptive run's checks grow apart with its length: the next one comes after
#: max(chunk, CHECK_GROWTH x the steps so far) (in whole chunks), so that a long run checks a
#: few hundred times, not once every 100 time units (each check reads the whole window), and
#: stops at most CHECK_GROWTH later than a check at every chunk would have
CHECK_GROWTH = 0.05


def next_check(step: int, chunk: int) -> int:
    """The first step after ``step`` at which an adaptive run checks its stop rule: the
    checks are c_0 = 0, c_k+1 = c_k + max(chunk, chunk floor(CHECK_GROWTH c_k / chunk)), the
    same for a run and for its continuation."""
    c = 0
    while c <= step:
        c += max(chunk, chunk * int(CHECK_GROWTH * c // chunk))
    return c


def _chunk(spec: RunSpec, chunk_steps: int | None) -> int:
    """Steps between checks of an adaptive run's stop rule: 1% of the run (at least 1000), at
    most ADAPTIVE_CHUNK_T; a fixed run has none (the whole run), unless ``chunk_steps``."""
    if chunk_steps:
        return chunk_steps
    if not spec.adaptive:
        return spec.n_steps
    chunk = max(1000, spec.n_steps // 100)
    return max(1, min(chunk, int(round(ADAPTIVE_CHUNK_T / spec.dt))))


#: runs this process has committed: a sweep's worker runs many, and pays Python's imports, the
#: plugin check and the loading of LAMMPS once (meta.json "process"); a forked worker starts
#: its own count (the pid tells)
_RUNS_IN_PROCESS = {"pid": None, "runs": 0}


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
    progress updates (default: 1% of the run, at least 1000 steps).
    ``force``: run even when the cost estimate (``bkflow.lammps.limits.check_cost``) is above
    the limits. ``path``: the integration path (``bkflow.model.params.PATHS``): ``auto`` (the
    fused path when it can run, as it always can for bkflow's lattices on the engine's one
    rank), ``general`` (fix nve + fix bk/substrate + fix enforce2d, bkflow before the fused
    path) or ``fused``; meta.json says which ran (``engine``).
    """
    options = DeckOptions(path=path)  # checks the path, before anything is created
    check_cost(spec, out, force)
    rd = RunDir(Path(out).absolute())
    with rd.lock():
        prior = None if overwrite else continuation(rd, spec)
        if prior is None:
            _claim(rd, overwrite)
        start = 0 if prior is None else int(prior["derived"]["n_steps"])
        dirs = [rd] + ([rd.companion()] if spec.companion is not None else [])
        if prior is not None:
            for d in dirs:
                d.begin_continuation()
        legs = [_Leg(spec, rd, options)]
        if spec.companion is not None:
            comp = rd.companion()
            if prior is None:
                comp.path.mkdir()
                comp.mark()
            # the companion keeps what the pair's verdict reads of it: its blocks, not its
            # extrema (the pair's slips are the main run's)
            legs.append(_Leg(spec.companion_spec, comp, options.replace(extrema=None)))
        if prior is None:
            for leg in legs:
                _write_inputs(leg.spec, leg.rd, leg.options)
        started = time.time() if prior is None else prior.get("started_epoch", time.time())
        bar = _Progress(spec.label, spec.n_steps, progress)
        try:
            for leg in legs:
                leg.open(None if prior is None else leg.rd.meta()["restart"], start)
            t_wall = time.perf_counter()
            step = _advance(legs, _chunk(spec, chunk_steps), bar, start) \
                if start < spec.n_steps else start
            wall = time.perf_counter() - t_wall
            counters = [leg.counters() for leg in legs]
            restarts = [leg.write_restart(step) for leg in legs]
        finally:
            bar.close()
            for leg in legs:
                leg.close()
        if step != spec.n_steps or prior is not None:  # the decks say what ran, from t = 0
            for leg in legs:
                _write_inputs(leg.spec, leg.rd, leg.options, steps=step)
        if _RUNS_IN_PROCESS["pid"] != os.getpid():
            _RUNS_IN_PROCESS.update(pid=os.getpid(), runs=0)
        process = {"pid": os.getpid(), "runs_before": _RUNS_IN_PROCESS["runs"]}
        metas = []
        for k, leg in enumerate(legs):
            before = prior if k == 0 or prior is None else leg.rd.meta()
            metas.append({**_meta(leg.spec, step, wall, started,
                                  {**counters[k], "process": process}, leg.adaptive, command,
                                  len(legs), before, start), "restart": restarts[k]})
        if len(legs) > 1:  # the companion is committed first: the run's record names it
            legs[1].rd.commit({**metas[1], "companion_of": ".."})
        meta = metas[0]
        if len(legs) > 1:
            meta["companion"] = {"start": spec.companion, "dir": COMPANION,
                                 "gap_at_stop": legs[0].adaptive.companion_gap
                                 if legs[0].adaptive is not None else None}
        result = RunResult(Path(out), rd.commit(meta))
        for d, name in zip(dirs, restarts):
            d.end_continuation(keep=name)
        _RUNS_IN_PROCESS["runs"] += 1
        return result


def continuation(rd: RunDir, spec: RunSpec) -> dict | None:
    """The completion record of the finished run in ``rd`` that ``spec`` continues, or None:
    the same run (every parameter but the length, and the companion's too) that ran fewer
    steps than ``spec`` asks for, and did not stop by its own rule, with its restart files.
    A longer run then continues from where it stopped and never simulates again what it has:
    its series are appended to, and its trajectory is the very one a longer request would
    have made (bit for bit on the fused path, whose restart is exact); its stop rule is
    checked at the steps of its own schedule, which the longer length may space otherwise."""
    legs = [rd] + ([rd.companion()] if spec.companion is not None else [])
    for d in legs:  # a continuation cut short: the finished run as it was
        d.undo_continuation()
    if not rd.is_complete() or rd.problem() is not None:
        return None
    meta = rd.meta()
    try:
        before = RunSpec.from_dict(meta["requested"])
        done = int(meta["derived"]["n_steps"])
    except Exception:  # a record of another version: not continued
        return None
    if before.replace(t_end=spec.t_end) != spec or spec.n_steps <= done:
        return None
    if before.adaptive and (meta.get("adaptive") or {}).get("reached"):
        return None   # it stopped by its own rule: a longer cap changes nothing
    if not all((d.meta() or {}).get("restart") and d.file(d.meta()["restart"]).is_file()
               for d in legs):
        return None
    return meta


def _meta(requested: RunSpec, step: int, wall: float, started: float, counters: dict,
          adaptive: AdaptiveStop | None, command: str | None, legs: int = 1,
          before: dict | None = None, start: int = 0) -> dict:
    """meta.json of a run that ran ``step`` steps (an adaptive run that met its target is a
    run of that length); ``legs``: the LAMMPS runs that shared the wall time (2 with a
    companion); ``before``: the record of the run this one continued from step ``start``
    (its wall time and counters add up, ``continued`` lists the parts)."""
    meta = _meta_fresh(requested, step, wall, started, counters, adaptive, command, legs,
                       step - start)
    if before is None:
        return meta
    meta["wall_time_s"] = before.get("wall_time_s", 0.0) + wall
    for key in ("slip_snapshots", "fronts"):   # the output fixes count from their restart
        if meta.get(key) and before.get(key):
            meta[key] = {k: v + before[key].get(k, 0) for k, v in meta[key].items()}
    # so do the overshoots (the breaks come back with the layer's restart state)
    meta["contact_overshoots"] = meta.get("contact_overshoots", 0) + before.get(
        "contact_overshoots", 0)
    meta["continued"] = before.get("continued", [{"to_step": start,
                                                   "command": before.get("command")}]) + [
        {"to_step": step, "command": command, "wall_time_s": wall}]
    meta["started"] = before.get("started", meta["started"])
    return meta


def _meta_fresh(requested: RunSpec, step: int, wall: float, started: float, counters: dict,
                adaptive: AdaptiveStop | None, command: str | None, legs: int,
                steps_run: int) -> dict:
    """meta.json of a run of ``step`` steps, ``steps_run`` of them in ``wall`` seconds."""
    stopped_early = step < requested.n_steps
    spec = requested.replace(t_end=step * requested.dt) if stopped_early else requested
    return {
        "bkflow": __version__,
        **lammps_version(),
        "plugin": build_info(),
        "provenance": provenance(),
        "params": spec.to_dict(),
        "requested": requested.to_dict(),
        "adaptive": None if adaptive is None else adaptive.record(requested, spec.t_end,
                                                                  stopped_early),
        "derived": {"N": spec.N, "k_b": spec.k_b, "dt": spec.dt, "dt_rule": spec.dt_rule,
                    "n_steps": step,
                    "stress_nevery": spec.stress_nevery,
                    "stress_dt": spec.stress_nevery * spec.dt,
                    "snapshot_nevery": spec.snapshot_nevery if spec.writes_snapshots else None,
                    "slip_threshold_stress": spec.slip_threshold_stress,
                    "transient_step": spec.transient_step},
        "scene": spec.scene,
        "seed": spec.seed,
        "wall_time_s": wall,
        "atom_steps_per_s": legs * spec.N * steps_run / wall if wall > 0 else None,
        **counters,
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(started)),
        "host": platform.node(),
        "command": command,
    }
