"""What a run keeps of its shear stress and of its contacts' phases: the records of fix
bk/reduce, reduced in the run (plugins/fix_bk_reduce.cpp), and the same reduction of a raw
series (a run of the ``series`` scene, or a run directory without fix bk/reduce's records).

Two NumPy files (``numpy.load`` reads them):

- ``extrema.npy``: the turning points of sigma_x by the zigzag rule (``bkflow.observables.stress``)
at the
  run's extrema threshold (``RunSpec.extrema_threshold_stress``, the smallest threshold any
  analysis asks for), maxima and minima in turn, the last one the extremum under way. The
  slips at any threshold at or above it are exactly those the same rule finds in these
  records (a drop larger than the threshold runs from one turning point to another):
  ``Reduced.events``. With the energy ledger (scenes events, full), each record also holds
  the breaks and the ledger at its sample.
- ``blocks.npy``: sums over blocks of ``RunSpec.block_nevery`` steps (BLOCK_EVERY time
  units): the stress samples and their sum, the phase samples and the sums of R, Z_re, Z_im,
  |Z|^2, R2, u_mean, u_std; with the ledger, its values at the block's last sample.

The analysis reads the series as block means (``Reduced.series``): the mean stress, its
trend test, its error (batch means) and the contacts' statistics all come from them, so that
a raw series and the run's own records give the same numbers (tests/observables/test_reduced.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bkflow.observables.stress import SlipEvents, Zigzag, slip_events

#: the contact breaks since the start and the energy ledger at a sample (docs/model.md
#: "Energy"): the fields the records add with the ledger (scenes events, full), and the columns
#: stress.csv has after t, sigma_x there (fix bk/stress ``energy``)
LEDGER_COLUMNS = ("breaks", "e_bond", "e_drive", "e_contact", "e_kinetic", "work", "diss_break",
                  "diss_damp")
#: the energy ledger's slots of fix bk/substrate's global vector (bkflow.lammps.deck.SLOTS): the
#: energies of the step, then the running sums that its keyword ``energy`` keeps; the ledger's
#: columns but the breaks (slot breaks_total)
LEDGER_SLOTS = LEDGER_COLUMNS[1:]
#: the phase statistics summed over a block (bkflow.store.rundir.PHASE_COLUMNS but t, and |Z|^2)
PHASE_SUMS = ("R", "Z_re", "Z_im", "Z2", "R2", "u_mean", "u_std")


class ReducedError(ValueError):
    """Records that cannot give what is asked (a threshold below the recorded one)."""


@dataclass(frozen=True)
class Reduced:
    """A run's reduced records: ``extrema`` and ``blocks`` (structured arrays, the fields of
    fix bk/reduce; ``extrema`` None for a companion run, which keeps its blocks only), the
    steps between stress samples (``nevery``) and per block (``block``), the time step, and
    the zigzag threshold of the extrema (stress units)."""

    extrema: np.ndarray | None
    blocks: np.ndarray
    nevery: int
    block: int
    dt: float
    threshold: float
    #: where the run kept its raw sigma_x series (scenes series, full): a function that reads
    #: it, for the slips below the recorded threshold (read only when they are asked for)
    raw: object = None
    #: ... and its ledger at every sample (scene full), for the slips that are no extrema
    raw_ledger: object = None

    @property
    def has_phase(self) -> bool:
        return "n_phase" in (self.blocks.dtype.names or ()) and bool(
            len(self.blocks) and self.blocks["n_phase"].sum() > 0)

    @property
    def has_extrema(self) -> bool:
        """Whether the run recorded its turning points (a companion run keeps its blocks
        only)."""
        return self.extrema is not None

    @property
    def has_ledger(self) -> bool:
        return self.has_extrema and "work" in (self.extrema.dtype.names or ())

    @property
    def n_samples(self) -> int:
        return int(self.blocks["n"].sum()) if len(self.blocks) else 0

    @property
    def t_end(self) -> float:
        """The time of the last stress sample."""
        return (self.n_samples - 1) * self.nevery * self.dt if self.n_samples else 0.0

    def sample_index(self) -> np.ndarray:
        """The stress sample of every extremum (its step / nevery)."""
        return np.asarray(self.extrema["step"], np.int64) // self.nevery

    def events(self, threshold: float) -> SlipEvents:
        """The slips of the run at ``threshold`` (stress units, at least the recorded one):
        what ``bkflow.observables.stress.slip_events`` finds in the whole series."""
        if not threshold >= self.threshold * (1 - 1e-12) and self.raw is not None:
            raw = self.raw()
            return slip_events(np.arange(len(raw)) * self.nevery * self.dt, raw, threshold)
        if not self.has_extrema:
            raise ReducedError("the run kept no record of its slips (a companion run keeps its "
                               "blocks only: the pair's slips are the main run's)")
        if not threshold >= self.threshold * (1 - 1e-12):
            raise ReducedError(
                f"the run recorded its slips down to a threshold of {self.threshold:.10g} "
                f"(stress units); {threshold:.10g} is smaller: only the raw series (scene "
                "series) can give it")
        s = np.asarray(self.extrema["sigma"], float)
        maxima, minima = Zigzag(threshold).feed(s.tolist())
        a, b = np.asarray(maxima, np.int64), np.asarray(minima, np.int64)
        i = self.sample_index()
        t = i * self.nevery * self.dt
        return SlipEvents(i[a], i[b], t[a], t[b], s[a], s[a] - s[b], float(threshold))

    def ledger_rows(self, i_max, i_min) -> tuple[dict, np.ndarray, np.ndarray]:
        """The ledger and the rows of it at the samples ``i_max``, ``i_min`` of slips (for
        bkflow.observables.catalogue.energy_rows): the extrema's, where every sample is an extremum
        (a threshold at or above the recorded one), else the raw series' (scene full)."""
        i = self.sample_index()
        rows = [np.searchsorted(i, np.asarray(x, np.int64)) for x in (i_max, i_min)]
        if all(np.array_equal(i[np.minimum(r, len(i) - 1)], x) if len(i) else not len(x)
               for r, x in zip(rows, (i_max, i_min))):
            return self.ledger_at_extrema(), rows[0], rows[1]
        if self.raw_ledger is not None:
            return self.raw_ledger(), np.asarray(i_max, int), np.asarray(i_min, int)
        raise ReducedError("the slips of this threshold are not the recorded extrema and the "
                           "run kept no raw ledger (scene full keeps it)")

    def series(self) -> tuple[np.ndarray, np.ndarray, dict | None]:
        """The block means: (t, sigma_x, phase), t the time of each block's first step,
        phase a dict of the means of PHASE_SUMS over the blocks with phase samples (and their
        own t), or None without phase records."""
        b = self.blocks
        n = np.asarray(b["n"], float)
        t = np.arange(len(b)) * self.block * self.dt
        sigma = np.asarray(b["sigma"], float) / n
        phase = None
        if self.has_phase:
            m = np.asarray(b["n_phase"], float)
            keep = m > 0
            phase = {"t": t[keep]}
            for c in PHASE_SUMS:
                phase[c] = np.asarray(b[c], float)[keep] / m[keep]
        return t, sigma, phase

    def weights(self) -> np.ndarray:
        """The stress samples of each block (the last block under way may hold fewer): the
        weights that make the mean of block means the mean of the samples."""
        return np.asarray(self.blocks["n"], float)

    def ledger_at_extrema(self) -> dict:
        """The breaks and the ledger at every extremum (``LEDGER_COLUMNS``)."""
        return {c: np.asarray(self.extrema[c], float) for c in LEDGER_COLUMNS}

    def ledger_at_blocks(self) -> dict:
        """The ledger at each block's last sample, stamped with the next block's first step's
        time (the window's edges): t and ``LEDGER_COLUMNS``."""
        out = {"t": (np.arange(len(self.blocks)) + 1) * self.block * self.dt}
        out.update({c: np.asarray(self.blocks[c], float) for c in LEDGER_COLUMNS})
        return out


def _pairs(dtype_fields) -> np.dtype:
    return np.dtype([(name, kind) for name, kind in dtype_fields])


def extrema_dtype(ledger: bool) -> np.dtype:
    return _pairs([("step", "<i8"), ("sigma", "<f8")]
                  + ([(c, "<f8") for c in LEDGER_COLUMNS] if ledger else []))


def blocks_dtype(phase: bool, ledger: bool) -> np.dtype:
    return _pairs([("n", "<i8")] + ([("n_phase", "<i8")] if phase else []) + [("sigma", "<f8")]
                  + ([(c, "<f8") for c in PHASE_SUMS] if phase else [])
                  + ([(c, "<f8") for c in LEDGER_COLUMNS] if ledger else []))


def from_series(sigma, nevery: int, block: int, dt: float, threshold: float,
                phase: dict | None = None, phase_nevery: int | None = None,
                ledger: dict | None = None) -> Reduced:
    """fix bk/reduce's records of a raw series: ``sigma`` sampled every ``nevery`` steps from
    step 0, ``phase`` (columns R, Z_re, Z_im, R2, u_mean, u_std) every ``phase_nevery``
    steps from step 0, ``ledger`` (``LEDGER_COLUMNS``) at every stress sample, or None."""
    s = np.asarray(sigma, float)
    n = len(s)
    steps = np.arange(n, dtype=np.int64) * nevery
    # the turning points, the last the one under way (as the plugin writes them)
    turns = _turning_points(s, threshold)
    ext = np.zeros(len(turns), extrema_dtype(ledger is not None))
    ext["step"] = steps[turns]
    ext["sigma"] = s[turns]
    if ledger is not None:
        for c in LEDGER_COLUMNS:
            ext[c] = np.asarray(ledger[c], float)[turns]
    k = steps // block
    nb = int(k[-1]) + 1 if n else 0
    with_phase = phase is not None and len(phase["R"]) > 0
    blk = np.zeros(nb, blocks_dtype(with_phase, ledger is not None))
    blk["n"] = np.bincount(k, minlength=nb)
    blk["sigma"] = _block_sums(k, s, nb)
    if with_phase:
        m = len(phase["R"])
        kp = (np.arange(m, dtype=np.int64) * phase_nevery) // block
        kp = kp[kp < nb]
        m = len(kp)
        blk["n_phase"] = np.bincount(kp, minlength=nb)
        zr, zi = np.asarray(phase["Z_re"], float)[:m], np.asarray(phase["Z_im"], float)[:m]
        cols = {"R": phase["R"], "Z_re": zr, "Z_im": zi, "Z2": zr * zr + zi * zi,
                "R2": phase["R2"], "u_mean": phase["u_mean"], "u_std": phase["u_std"]}
        for c in PHASE_SUMS:
            blk[c] = _block_sums(kp, np.asarray(cols[c], float)[:m], nb)
    if ledger is not None and n:
        last = np.r_[np.flatnonzero(np.diff(k)), n - 1]
        for c in LEDGER_COLUMNS:
            blk[c] = np.asarray(ledger[c], float)[last]
    return Reduced(ext, blk, nevery, block, dt, float(threshold))


def _block_sums(k, x, nb: int) -> np.ndarray:
    """Sums of ``x`` over the blocks ``k`` (non-decreasing), in sample order as the plugin
    adds them."""
    out = np.zeros(nb)
    if len(x):
        cut = np.r_[0, np.flatnonzero(np.diff(k)) + 1, len(x)]
        for a, b in zip(cut[:-1], cut[1:]):
            acc = 0.0
            for v in x[a:b].tolist():
                acc += v
            out[k[a]] = acc
    return out


def _turning_points(s: np.ndarray, threshold: float) -> np.ndarray:
    """The samples fix bk/reduce records: each maximum once the series fell from it by more
    than ``threshold``, each minimum once it rose again by more, and the extremum under way:
    the zigzag rule's confirmed pairs in turn, then its state at the end."""
    if not len(s):
        return np.zeros(0, np.int64)
    z = Zigzag(threshold)
    maxima, minima = z.feed(s.tolist())
    tail = [z.imax, z.imin] if z.falling else [z.imax]   # a final maximum, the one under way
    return np.asarray([i for pair in zip(maxima, minima) for i in pair] + tail, np.int64)


#: the fields of the plugin's other records (fix bk/slips ``catalogue``, fix bk/psi, and the
#: raw series of fix bk/stress and bk/phase)
SLIP_FIELDS = ("step_max", "step_min", "n_slipped", "n_clusters", "cluster_n", "cluster_nx",
               "cluster_ny", "potency", "slip_mean", "slip_max", "cluster_lx", "cluster_ly")
CLUSTER_FIELDS = ("step_max", "label", "n_c", "n_x", "n_y", "l_x", "l_y", "slip",
                  "bond_change", "eq2_estimate")
PSI_FIELDS = ("step", "psi")
SERIES_FIELDS = (("step", "sigma"), ("step", "sigma", *LEDGER_COLUMNS),
                 ("step", "R", "Z_re", "Z_im", "R2", "u_mean", "u_std"))


#: the records' fields that count or index (int64, never negative); every other is float64
COUNT_FIELDS = frozenset(("step", "step_max", "step_min", "n", "n_phase", "n_slipped",
                          "n_clusters", "cluster_n", "cluster_nx", "cluster_ny", "label", "n_c",
                          "n_x", "n_y"))
#: float fields whose value is NaN where the count they are of is 0: a slip that formed no
#: cluster has no extents, one that moved no particle past S_x has no mean or largest slip
NAN_WHERE_NONE = {"cluster_lx": "n_clusters", "cluster_ly": "n_clusters",
                  "slip_mean": "n_slipped", "slip_max": "n_slipped"}


def checked(records: np.ndarray, layouts, what: str, lattice: tuple | None = None
            ) -> np.ndarray:
    """``records`` when they are what the plugin writes: one dimension, the fields of one of
    ``layouts`` (tuples of names), each of its own type (``COUNT_FIELDS`` little-endian int64,
    the others float64), every float finite (but where ``NAN_WHERE_NONE`` allows NaN), and
    every value within the bounds the model gives it (``bounds_problem``;
    ``lattice`` (Lx, Ly) adds those of the lattice); ValueError naming ``what`` otherwise."""
    got = records.dtype.names or ()
    if isinstance(layouts[0], str):
        layouts = (layouts,)
    if records.ndim != 1 or got not in layouts:
        raise ValueError(f"{what} holds {records.dtype} of shape {records.shape}, not the "
                         f"records of fields {', '.join(layouts[0])}")
    for name in got:
        want = "<i8" if name in COUNT_FIELDS else "<f8"
        kind = records.dtype[name]
        if kind.str != want:
            raise ValueError(f"{what}: field {name} is {kind.str}, not {want}")
        if kind.kind == "f":
            values = records[name]
            if name in NAN_WHERE_NONE and NAN_WHERE_NONE[name] in got:
                values = values[records[NAN_WHERE_NONE[name]] > 0]
            if not np.isfinite(values).all():
                raise ValueError(f"{what}: field {name} holds NaN or infinity")
    problem = bounds_problem(records, lattice)
    if problem:
        raise ValueError(f"{what}: {problem}")
    return records


# complexity: one table of the model's bounds, a branch for each family of fields present
def _bounds(r: np.ndarray, lattice: tuple | None) -> list:
    """(what, which rows break it) for each bound the model gives the fields of ``r``: counts
    never negative; a sample's phase coherence R, R2, |Z|^2 in [0, 1], Z's parts in [-1, 1],
    u in [0, 1) with spread at most 1/2 (in blocks, summed over their ``n_phase`` samples);
    Psi in [0, 1]; a slip ends after it starts, its clusters and their particles are no more
    than its slipped particles, its slips are not negative; with ``lattice`` (Lx, Ly), no count
    above the lattice's and no extent above twice its side (a cluster filling the box has
    l_x = Lx N/(N - 1))."""
    names = set(r.dtype.names)
    tol = 1e-9
    out = [(f"{f} is negative", r[f] < 0) for f in sorted(names & COUNT_FIELDS)]
    per = r["n_phase"].astype(float) if "n_phase" in names else (
        1.0 if "R" in names else None)
    if per is not None:
        for f, lo, hi in (("R", 0, 1), ("R2", 0, 1), ("Z2", 0, 1), ("Z_re", -1, 1),
                          ("Z_im", -1, 1), ("u_mean", 0, 1), ("u_std", 0, 0.5)):
            if f in names:
                out.append((f"{f} lies outside [{lo}, {hi}] per sample",
                            (r[f] < lo * per - tol * (1 + per))
                            | (r[f] > hi * per + tol * (1 + per))))
    if "psi" in names:
        out.append(("psi lies outside [0, 1]", (r["psi"] < -tol) | (r["psi"] > 1 + tol)))
    if {"step_max", "step_min"} <= names:
        out.append(("a slip ends before it starts", r["step_min"] < r["step_max"]))
    if "n_slipped" in names:
        for f in ("n_clusters", "cluster_n"):
            out.append((f"{f} exceeds n_slipped", r[f] > r["n_slipped"]))
    for small, big in (("cluster_nx", "cluster_n"), ("cluster_ny", "cluster_n"),
                       ("n_x", "n_c"), ("n_y", "n_c"), ("slip_mean", "slip_max")):
        if {small, big} <= names:
            out.append((f"{small} exceeds {big}", r[small] > r[big] * (1 + tol) + tol))
    for f in ("potency", "slip_mean", "slip_max", "l_x", "l_y", "cluster_lx", "cluster_ly"):
        if f in names:
            out.append((f"{f} is negative", r[f] < 0))
    if lattice is not None:
        lx, ly = lattice
        n = lx * ly
        for f in ("n_slipped", "n_clusters", "cluster_n", "n_c"):
            if f in names:
                out.append((f"{f} exceeds the lattice's {n} particles", r[f] > n))
        for f, side in (("cluster_nx", lx), ("n_x", lx), ("cluster_ny", ly), ("n_y", ly),
                        ("cluster_lx", lx), ("l_x", lx), ("cluster_ly", ly), ("l_y", ly)):
            if f in names:
                cap = side if f.endswith(("nx", "ny", "n_x", "n_y")) else 2 * side
                out.append((f"{f} exceeds {cap:g}", r[f] > cap))
    return out


def bounds_problem(records: np.ndarray, lattice: tuple | None = None) -> str | None:
    """The first bound of ``_bounds`` that rows of ``records`` break, with how many and the
    first one's value; None when every value holds (NaN counts as holding: ``checked`` says
    where NaN belongs)."""
    for what, bad in _bounds(records, lattice):
        bad = np.asarray(bad)
        if bad.any():
            return (f"{what} in {int(bad.sum())} of {len(records)} row(s) (the first: row "
                    f"{int(np.argmax(bad))})")
    return None


def checked_extrema(extrema: np.ndarray, name: str) -> np.ndarray:
    """fix bk/reduce's extrema as read (``name``: its file's, for the message): ValueError
    where they are not a record of extrema or their steps do not increase."""
    ext = checked(extrema, tuple(extrema_dtype(ledger).names for ledger in (False, True)), name)
    if len(ext) and (np.diff(ext["step"]) <= 0).any():
        raise ValueError(f"{name}: its steps do not increase")
    return ext


def checked_blocks(blocks: np.ndarray, name: str) -> np.ndarray:
    """fix bk/reduce's block sums as read (``name``: its file's): ValueError where they are not
    a record of blocks."""
    return checked(blocks, tuple(blocks_dtype(p, ledger).names for p in (True, False)
                                 for ledger in (False, True)), name)
