"""Reading a run's records: what LAMMPS and the plugin's fixes wrote in a run directory, as
arrays (the reduced records, the raw series, Psi(t), the slips' rows, dumps and fronts).

``RunReaders`` is a part of ``bkflow.store.rundir.RunDir`` (``RunDir(path).read_reduced(spec)``
and the other ``read_*`` methods). A record that cannot be read as what it should hold is a
``DamagedRunError`` naming the file; the file system's refusal (missing, unreadable) is its own
OSError.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from bkflow.model.params import RunSpec
from bkflow.observables import reduced
from bkflow.observables.reduced import LEDGER_COLUMNS
from bkflow.store import files, formats
from bkflow.store.errors import AnalysisError, DamagedRunError
from bkflow.store.layout import (
    BLOCKS,
    CLUSTER_ROWS,
    DECK,
    EXTREMA,
    FRONTS,
    META,
    PHASE,
    PHASE_COLUMNS,
    PSI_RECORD,
    SERIES_PHASE,
    SERIES_STRESS,
    SLIP_ROWS,
    SLIPS,
    SNAPSHOTS,
    STRESS,
    RunFiles,
)


class RunReaders(RunFiles):
    """The readers of a run's records (a part of ``RunDir``; a record without its parameters
    is read with ``RunDir.spec``'s, and a deck's threshold with ``RunDir.meta``'s)."""

    def recorded_threshold(self, spec: RunSpec) -> float:
        """The zigzag threshold the run's extrema were recorded at: its deck's fix bk/reduce
        line says it (a run recorded under another rule of RunSpec.extrema_threshold_stress,
        e.g. one without the size-scaled threshold, keeps its own), else the spec's."""
        import re

        try:
            deck = formats.read_text(self.file(DECK), errors="replace")
        except OSError:
            return spec.extrema_threshold_stress
        m = re.search(r"bk/reduce\s+\S+\s+\S+\s+threshold\s+(\S+)", deck)
        try:
            return float(m.group(1)) if m else spec.extrema_threshold_stress
        except ValueError:
            return spec.extrema_threshold_stress

    def _extrema(self) -> np.ndarray | None:
        """fix bk/reduce's extrema (None: a companion keeps its blocks only; a finished run's
        missing file is found by problem() before)."""
        if not self.file(EXTREMA).exists():
            return None
        return reduced.checked_extrema(np.load(files.regular(self.file(EXTREMA)),
                                               allow_pickle=False), EXTREMA)

    def read_reduced(self, spec: RunSpec):
        """The run's records of its stress and phases (``bkflow.observables.reduced.Reduced``):
        fix bk/reduce's, or the same reduction of the raw series of a run that has no records
        (a run written before bkflow reduced in the run)."""
        args = (spec.stress_nevery, spec.block_nevery, spec.dt, self.recorded_threshold(spec))
        if self.file(BLOCKS).exists() or not self.file(STRESS).exists():
            try:
                # a companion keeps its blocks only (no extrema.npy; a finished run's
                # missing file is found by problem() before)
                ext = self._extrema()
                blk = reduced.checked_blocks(np.load(files.regular(self.file(BLOCKS)),
                                                     allow_pickle=False), BLOCKS)
                red = reduced.Reduced(ext, blk, *args[:3], float(args[3]))
                if self.file(SERIES_STRESS).exists():   # scenes series, full: every slip
                    red = dataclasses.replace(red, raw=lambda: self.read_stress(spec)[1],
                                              raw_ledger=lambda: self.read_ledger(spec))
            except (ValueError, EOFError, OSError) as exc:
                if isinstance(exc, OSError) and exc.errno is not None:
                    raise   # the file system's refusal (missing, unreadable), not damage
                raise DamagedRunError(f"{self.path}: its records ({EXTREMA}, {BLOCKS}) are "
                                      f"damaged ({exc}); run the run again") from None
            return red
        _, sigma = self.read_stress(spec)
        phase = self.read_phase(spec)
        ledger = self.read_ledger(spec) if spec.writes_energy else None
        return reduced.from_series(sigma, *args[:3], args[3], phase, spec.phase_nevery, ledger)

    def stress_outline(self, spec: RunSpec) -> tuple[np.ndarray, np.ndarray]:
        """sigma_x(t) as the run kept it: the raw series where its scene wrote it (series,
        full), else its turning points (``EXTREMA``: every maximum and minimum of the drops
        above the extrema threshold, the stick-slip's outline)."""
        if self.keeps_raw_stress():
            return self.read_stress(spec)
        red = self.read_reduced(spec)
        if not red.has_extrema:
            raise AnalysisError(f"{self.path} keeps its stress as block means only (a companion "
                                "run): read them as Run.blocks")
        return red.sample_index() * spec.stress_nevery * spec.dt, \
            np.asarray(red.extrema["sigma"], float)

    def keeps_raw_stress(self) -> bool:
        """Whether the run kept its raw stress series (scenes series, full; a run written
        before bkflow 0.5 kept it as stress.csv)."""
        return self.file(SERIES_STRESS).exists() or self.file(STRESS).exists()

    def phase_series(self, spec: RunSpec, red=None) -> dict | None:
        """The contacts' phase statistics as the run kept them: the raw series where its
        scene wrote it (phase.npy), else their means over the blocks (``BLOCKS``, of ``red``
        where the caller has read the records already); None without phases."""
        if self.file(SERIES_PHASE).exists() or self.file(PHASE).exists() or \
                not self.file(BLOCKS).exists():
            return self.read_phase(spec)
        _, _, phase = (red or self.read_reduced(spec)).series()
        return phase

    def _series(self, name: str, spec: RunSpec | None = None):
        """A raw series' records (stress.npy, phase.npy) and the time step of ``spec`` (the
        run's own by default)."""
        from bkflow.observables.reduced import SERIES_FIELDS, checked

        try:
            r = checked(np.load(files.regular(self.file(name)), allow_pickle=False),
                        SERIES_FIELDS, name)
        except (ValueError, EOFError) as exc:
            raise DamagedRunError(f"{self.file(name)} is damaged ({exc}); run the run "
                                  "again") from None
        return r, (spec or self.spec()).dt

    def read_stress(self, spec: RunSpec | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The raw stress series: (t, sigma_x) (stress.npy; stress.csv of a run written
        before bkflow 0.5).
        ``spec``: the run's parameters where the directory has no record of them."""
        if self.file(SERIES_STRESS).exists():
            r, dt = self._series(SERIES_STRESS, spec)
            return np.asarray(r["step"], float) * dt, np.asarray(r["sigma"], float)
        try:
            c = formats.read_columns(self.file(STRESS), ("t", "sigma_x"))
        except FileNotFoundError:
            raise
        except ValueError as exc:
            raise DamagedRunError(f"{self.file(STRESS)} is damaged ({exc})") from None
        return c["t"], c["sigma_x"]

    def read_ledger(self, spec: RunSpec | None = None) -> dict | None:
        """The breaks and the energy ledger at every stress sample (stress.csv of a scene that
        keeps it: ``LEDGER_COLUMNS``), or None."""
        if self.file(SERIES_STRESS).exists():
            r, dt = self._series(SERIES_STRESS, spec)
            if "work" not in (r.dtype.names or ()):
                return None
            return {"t": np.asarray(r["step"], float) * dt,
                    **{c: np.asarray(r[c], float) for c in LEDGER_COLUMNS}}
        path = self.file(STRESS)
        with open(path, "rb") as f:
            head = f.readline().decode(errors="replace").strip().split(",")
        if head[2:] != list(LEDGER_COLUMNS):
            return None
        try:
            ledger = formats.read_columns(path, ("t", *LEDGER_COLUMNS))
        except ValueError as exc:
            raise DamagedRunError(f"{path} is damaged ({exc})") from None
        sums = ("work", "diss_break", "diss_damp")
        if all(np.isnan(ledger[c]).all() for c in sums):  # a substrate fix without `energy`
            return None
        bad = np.zeros(len(ledger["t"]), bool)
        for c in ("t", *LEDGER_COLUMNS):
            bad |= ~np.isfinite(ledger[c])
        if bad.any():
            raise DamagedRunError(f"{path} is damaged: {int(bad.sum())} row(s) without every "
                                  f"column of its header (the first near t = "
                                  f"{ledger['t'][bad][0]:g}); run the run again")
        return ledger

    def read_phase(self, spec: RunSpec | None = None):
        """The contacts' phase series (phase.csv): a dict of float columns t, R, Z_re, Z_im,
        R2, u_mean, u_std; None for a run made before bkflow recorded it."""
        if self.file(SERIES_PHASE).exists():
            r, dt = self._series(SERIES_PHASE, spec)
            return {"t": np.asarray(r["step"], float) * dt,
                    **{c: np.asarray(r[c], float) for c in PHASE_COLUMNS[1:]}}
        if not self.file(PHASE).exists():
            if PHASE in ((self.meta() or {}).get("file_bytes") or {}):
                raise DamagedRunError(f"{self.file(PHASE)} is missing ({META} lists it)")
            return None
        try:
            return formats.read_columns(self.file(PHASE), PHASE_COLUMNS)
        except ValueError as exc:
            raise DamagedRunError(f"{self.file(PHASE)} is damaged ({exc})") from None

    def read_snapshots(self, n_atoms: int) -> formats.Frames:
        return self._frames(SNAPSHOTS, n_atoms)

    def read_fronts(self) -> list[formats.Front]:
        """The rupture fronts of the run (fix bk/fronts, scenes fronts and full): one
        ``bkflow.store.formats.Front`` per recorded slip; [] when the scene recorded none."""
        if not self.file(FRONTS).exists():
            meta = self.meta() or {}
            if (meta.get("fronts") or {}).get("written"):
                raise DamagedRunError(f"{self.file(FRONTS)} is missing ({META} says "
                                      f"{meta['fronts']['written']} slips were recorded)")
            return []
        try:
            return formats.read_fronts(self.file(FRONTS))
        except ValueError as exc:
            raise DamagedRunError(f"{self.file(FRONTS)} is cut or damaged ({exc})") from None

    def read_slip_frames(self, n_atoms: int) -> formats.Frames:
        return self._frames(SLIPS, n_atoms)

    def _frames(self, name: str, n_atoms: int) -> formats.Frames:
        try:
            return formats.read_frames(self.file(name), n_atoms)
        except (OSError, MemoryError):  # missing, unreadable, the machine's limit: named
            raise
        except Exception as exc:  # MDAnalysis reports a cut dump in many ways
            raise DamagedRunError(f"{self.file(name)} is cut or damaged "
                                  f"({type(exc).__name__}: {exc})") from None

    def read_psi_record(self, spec: RunSpec):
        """Psi(t) as fix bk/psi computed it in the run: (steps, psi), or None."""
        if not self.file(PSI_RECORD).exists():
            return None
        try:
            from bkflow.observables.reduced import PSI_FIELDS, checked

            r = checked(np.load(files.regular(self.file(PSI_RECORD)), allow_pickle=False),
                        PSI_FIELDS, PSI_RECORD)
            return np.asarray(r["step"], np.int64), np.asarray(r["psi"], float)
        except (ValueError, EOFError, KeyError) as exc:
            raise DamagedRunError(f"{self.file(PSI_RECORD)} is damaged ({exc}); run the run "
                                  "again") from None

    def read_slip_rows(self, spec: RunSpec | None = None):
        """(slips, clusters): each slip's catalogue row and its clusters as the run computed
        them (fix bk/slips ``catalogue``; structured arrays)."""
        from bkflow.observables.reduced import CLUSTER_FIELDS, SLIP_FIELDS, checked

        lattice = None if spec is None else (spec.Lx, spec.Ly)   # the bounds of its lattice too
        out = []
        for name, fields in ((SLIP_ROWS, SLIP_FIELDS), (CLUSTER_ROWS, CLUSTER_FIELDS)):
            try:
                out.append(checked(np.load(files.regular(self.file(name)), allow_pickle=False),
                                   fields, name, lattice=lattice))
            except (ValueError, EOFError) as exc:
                raise DamagedRunError(f"{self.file(name)} is damaged ({exc}); run the run "
                                      "again") from None
        return tuple(out)
