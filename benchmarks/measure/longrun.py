"""Long runs that record block averages and can resume: the ground truth of the benchmarks.

A run of 10^6-10^7 time units writes 0.5-5 GB of stress and phase series at bkflow's sampling
(a sample every 0.1 time units); the benchmarks need only block averages. ``LongRun`` runs the
deck of a ``RunSpec`` (scene series) in chunks, each one LAMMPS instance that starts from the
last chunk's restart file (the fused path continues a restart bit for bit), reduces the
chunk's series into blocks of ``block_t`` time units, deletes them, and appends the blocks to
a Parquet record; the zigzag state of the slip search goes with the restart file into
state.json, whose atomic replacement commits the chunk (the restart file is named by the
blocks it follows). Killed at any point, it resumes from the last chunk it committed.

Per block (time units [t0, t1)): the samples n, the mean of sigma_x / sigma_n and of its
square, the contacts' phase statistics (mean R = |Z|, mean |Z|^2, mean Z, so that the phase
fluctuation chi = N (<|Z|^2> - |<Z>|^2) of the block or of any union of blocks follows), and for
each slip threshold in ``THRESHOLDS`` (fractions of mu_s sigma_n) the slips whose maximum lies
in the block: their count, the sum of sigma_fail / sigma_n and the sum of their drops.

    python -m benchmarks.measure.longrun PHI N START SEED T_END [--dt-factor C] [--block T]

runs one into benchmarks/records/scratch/ (the measurements call ``LongRun`` directly).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import time
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.harness import RECORDS, parser
from bkflow.lammps.deck import DeckOptions, continue_text, data_text, setup_text
from bkflow.lammps.plugin import open_lammps
from bkflow.model.params import RunSpec
from bkflow.observables.stress import Zigzag
from bkflow.store.formats import write_json_atomic

#: slip thresholds of the records, fractions of mu_s sigma_n
THRESHOLDS = (0.001, 0.01, 0.03, 0.1)
#: where the runs keep their restart files and series while they run (not committed)
WORK = Path(os.environ.get("BKFLOW_LONGRUN_WORK", "runs/longrun"))

COLUMNS = ["t0", "t1", "n", "s", "s2", "R", "R2abs", "Zre", "Zim"] + [
    f"{kind}_{thr:g}" for thr in THRESHOLDS for kind in ("nslip", "sfail", "drop")]


def case_name(spec: RunSpec) -> str:
    return f"N{spec.N}_phi{spec.phi:g}_{spec.start}_s{spec.seed}_C{spec.dt_factor:g}"


class LongRun:
    """One long run of ``spec`` (its t_end is ignored: ``advance_to`` says how far), recorded
    into ``record`` (Parquet) in blocks of ``block_t`` time units, chunks of ``chunk_t``."""

    def __init__(self, spec: RunSpec, record: Path, block_t: float = 1000.0,
                 chunk_t: float = 20000.0, work: Path | None = None):
        # scene series: the raw stress and phase series, which each chunk reduces to blocks
        self.spec = spec.replace(scene="series", companion=None, target_error=None,
                                 until_steady=False)
        self.record = Path(record)
        # one scratch directory per record: two benchmarks may record runs of the same name
        # (benchmarks/records/<benchmark>/<case>), and must never share one
        self.work = Path(work or WORK) / self.record.parent.name / self.record.stem
        self.legacy = Path(work or WORK) / self.record.stem
        dt = self.spec.dt
        ns = self.spec.stress_nevery
        self.block_steps = max(1, round(block_t / dt / ns)) * ns
        self.chunk_blocks = max(1, round(chunk_t / (self.block_steps * dt)))
        self.state_file = self.work / "state.json"

    # ------------------------------------------------------------------ state on disk
    def _adopt(self, legacy: Path) -> None:
        """Take over the scratch directory of the layout before (one per record name) when
        its state is this record's (its spec, and as many blocks as the record holds)."""
        try:
            st = json.loads((legacy / "state.json").read_text())
            was, now = st.get("spec", {}), self.spec.to_dict()
            same = (self.record.exists() and was
                    and all(was[k] == now[k] for k in set(was) & set(now) - {"scene"})
                    and len(pd.read_parquet(self.record)) == st["blocks"])
        except (OSError, ValueError):
            same = False
        if same:
            self.work.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(str(legacy), str(self.work))

    def _state(self) -> dict:
        if self.record.exists() and self.state_file.exists():
            st = json.loads(self.state_file.read_text())
            rec = pd.read_parquet(self.record)
            if len(rec) == st["blocks"]:
                return st
            if len(rec) > st["blocks"]:  # the record was written, the state was not
                pd.DataFrame(rec.iloc[:st["blocks"]]).to_parquet(self.record, index=False)
                return st
        if self.record.exists() and len(pd.read_parquet(self.record)):
            # a record whose run state is gone cannot be extended, and is never thrown away
            raise SystemExit(f"{self.record}: its run's state ({self.work}) is gone or is "
                             "another run's, so it cannot go on; it is kept as it is (move it "
                             "away to run the case again from the start)")
        # nothing recorded yet: start
        if self.work.exists():
            shutil.rmtree(self.work)
        self.record.unlink(missing_ok=True)
        return {"blocks": 0, "step": 0, "zigzag": None, "wall_s": 0.0,
                "spec": self.spec.to_dict(), "block_steps": self.block_steps}

    @property
    def t_done(self) -> float:
        if not self.state_file.exists():
            return 0.0
        return json.loads(self.state_file.read_text())["step"] * self.spec.dt

    def advance_to(self, t_end: float, log=print) -> pd.DataFrame:
        """Run until the record holds every block up to ``t_end``; the record."""
        spec = self.spec
        target_blocks = int(math.ceil(t_end / (self.block_steps * spec.dt) - 1e-9))
        if self.record.exists() and not self.state_file.exists():
            rec = pd.read_parquet(self.record)
            if len(rec) >= target_blocks:   # as long as asked: nothing to run, nothing to check
                return rec
        if not self.work.exists() and (self.legacy / "state.json").exists():
            self._adopt(self.legacy)
        st = self._state()
        self.work.mkdir(parents=True, exist_ok=True)
        self.record.parent.mkdir(parents=True, exist_ok=True)
        was, now = st.get("spec", spec.to_dict()), spec.to_dict()
        # fields added since, and what a run writes (its scene), do not change the run
        if any(was[k] != now[k] for k in set(was) & set(now) - {"scene"}):
            raise SystemExit(f"{self.record}: recorded with other parameters")
        while st["blocks"] < target_blocks:
            nb = min(self.chunk_blocks, target_blocks - st["blocks"])
            t0 = time.perf_counter()
            rows, zz, carry = self._chunk(st, nb)
            wall = time.perf_counter() - t0
            if self.record.exists() and st["blocks"]:
                old = pd.read_parquet(self.record)
                for c, v in carry.items():  # slips confirmed now, their maximum before
                    old.loc[old.index[-1], c] += v
                rec = pd.concat([old, rows], ignore_index=True)
            else:
                rec = rows
            tmp = self.record.with_suffix(".tmp")
            rec.to_parquet(tmp, index=False)
            os.replace(tmp, self.record)
            st = {**st, "blocks": st["blocks"] + nb, "step": st["step"] + nb * self.block_steps,
                  "zigzag": zz, "wall_s": st["wall_s"] + wall}
            write_json_atomic(self.state_file, st)  # the commit: the new restart file is named
            for old in self.work.glob("b*.restart"):
                if old.name != f"b{st['blocks']}.restart":
                    old.unlink()
            log(f"{self.record.stem}: t = {st['step'] * spec.dt:.0f} of {t_end:g} "
                f"({wall:.1f} s this chunk, <sigma>/sigma_n {rows['s'].mean():.5f}, "
                f"R {rows['R'].mean():.3f})")
        return pd.read_parquet(self.record)

    # ------------------------------------------------------------------ one chunk
    def _chunk(self, st: dict, nb: int):
        spec, w = self.spec, self.work
        for name in ("stress.csv", "phase.csv"):
            (w / name).unlink(missing_ok=True)
        steps = nb * self.block_steps
        opts = DeckOptions(data="data.bk", stress="stress.csv", phase="phase.csv",
                           thermo_every=10**9, path="auto")
        with contextlib.chdir(w):
            lmp = open_lammps()
            try:
                lmp.command("variable comm_cutoff index 0.1")
                if st["step"] == 0:
                    Path("data.bk").write_text(data_text(spec))
                    lmp.commands_string(setup_text(spec, opts))
                else:
                    lmp.commands_string(continue_text(spec, f"b{st['blocks']}.restart",
                                                      opts.replace(data="")))
                lmp.command(f"run {steps}")
                lmp.command(f"write_restart b{st['blocks'] + nb}.restart")
            finally:
                lmp.close()
        return self._reduce(st, nb)

    def _reduce(self, st: dict, nb: int):
        spec, w = self.spec, self.work
        dt = spec.dt
        s = pd.read_csv(w / "stress.csv").to_numpy()
        p = pd.read_csv(w / "phase.csv").to_numpy()
        step0 = st["step"]
        # samples after the chunk's start (a continued run writes its first step again)
        t_start = step0 * dt
        s = s[s[:, 0] > t_start + 0.5 * dt * spec.stress_nevery]
        p = p[p[:, 0] > t_start + 0.5 * dt * spec.stress_nevery]
        if step0 == 0:  # the very first sample, t = 0, belongs to block 0
            s0 = pd.read_csv(w / "stress.csv").to_numpy()[:1]
            s = np.vstack([s0, s])
        edges = (step0 + self.block_steps * np.arange(nb + 1)) * dt
        sig = s[:, 1] / spec.sigma_n
        k = np.clip(np.searchsorted(edges, s[:, 0] + 1e-9 * dt, side="right") - 1, 0, nb - 1)
        kp = np.clip(np.searchsorted(edges, p[:, 0] + 1e-9 * dt, side="right") - 1, 0, nb - 1)
        cnt = np.bincount(k, minlength=nb)
        cntp = np.bincount(kp, minlength=nb)
        zre, zim = p[:, 2], p[:, 3]
        rows = {"t0": edges[:-1], "t1": edges[1:], "n": cnt,
                "s": np.bincount(k, sig, nb) / cnt, "s2": np.bincount(k, sig ** 2, nb) / cnt,
                "R": np.bincount(kp, np.hypot(zre, zim), nb) / cntp,
                "R2abs": np.bincount(kp, zre ** 2 + zim ** 2, nb) / cntp,
                "Zre": np.bincount(kp, zre, nb) / cntp, "Zim": np.bincount(kp, zim, nb) / cntp}
        zz_state = st["zigzag"] or {}
        new_state, carry = {}, {}
        for thr in THRESHOLDS:
            key = f"{thr:g}"
            z = Zigzag(thr * spec.friction_threshold)
            if key in zz_state:
                z.__dict__.update(zz_state[key]["z"])
                tail_t = np.array(zz_state[key]["tail_t"])
                tail_s = np.array(zz_state[key]["tail_s"])
            else:
                tail_t = tail_s = np.array([])
            # the zigzag counts samples from its first: keep the times of the samples it may
            # still refer to (the open maximum and minimum) beside it
            n0 = z.n
            tt = np.concatenate([tail_t, s[:, 0]])
            ss = np.concatenate([tail_s, s[:, 1]])
            base = n0 - len(tail_t)
            maxima, minima = z.feed(s[:, 1].tolist())
            imax = np.array(maxima, int) - base
            imin = np.array(minima, int) - base
            tm = tt[imax] if len(imax) else np.array([])
            # block -1: a maximum in the last block of the chunk before, confirmed in this one
            kb = np.searchsorted(edges, tm + 1e-9 * dt, side="right") - 1
            kb = np.minimum(kb, nb - 1) + 1
            fail = ss[imax] / spec.sigma_n if len(imax) else np.array([])
            drop = (ss[imax] - ss[imin]) if len(imax) else np.array([])
            for kind, wt in (("nslip", None), ("sfail", fail), ("drop", drop)):
                sums = np.bincount(kb, wt, nb + 1) if len(imax) else np.zeros(nb + 1)
                rows[f"{kind}_{key}"] = sums[1:]
                carry[f"{kind}_{key}"] = sums[0]
            keep_from = z.imax - base  # the open maximum, and all after it
            new_state[key] = {"z": dict(z.__dict__), "tail_t": tt[keep_from:].tolist(),
                              "tail_s": ss[keep_from:].tolist()}
        df = pd.DataFrame(rows)[COLUMNS]
        for c in COLUMNS:
            df[c] = df[c].astype(np.int64 if c == "n" or c.startswith("nslip") else np.float64)
        for name in ("stress.csv", "phase.csv"):
            (w / name).unlink(missing_ok=True)
        return df, new_state, carry


def chi(rec: pd.DataFrame, N: int) -> float:
    """The phase fluctuation chi = N <|Z - <Z>|^2> over the blocks of ``rec`` (weighted by
    their samples)."""
    wgt = rec["n"].to_numpy(float)
    m2 = np.average(rec["R2abs"], weights=wgt)
    zr = np.average(rec["Zre"], weights=wgt)
    zi = np.average(rec["Zim"], weights=wgt)
    return float(N * (m2 - zr ** 2 - zi ** 2))


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("phi", type=float)
    ap.add_argument("N", type=int)
    ap.add_argument("start")
    ap.add_argument("seed", type=int)
    ap.add_argument("t_end", type=float)
    ap.add_argument("--dt-factor", type=float, default=None)
    ap.add_argument("--block", type=float, default=1000.0)
    a = ap.parse_args(argv)
    from bkflow.model.params import size_from_n

    Lx, Ly = size_from_n(a.N)
    spec = RunSpec(phi=a.phi, Lx=Lx, Ly=Ly, seed=a.seed, start=a.start)
    if a.dt_factor is not None:
        spec = spec.replace(dt_factor=a.dt_factor)
    lr = LongRun(spec, RECORDS / "scratch" / f"{case_name(spec)}.parquet", a.block)
    rec = lr.advance_to(a.t_end)
    print(rec.tail())


if __name__ == "__main__":
    main()
