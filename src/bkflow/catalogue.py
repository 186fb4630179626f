"""The event catalogue: one row per slip, with its size, shape, nucleation site, rupture front
and energy budget (docs/model.md "Energy"; the scenes events and full record what it needs).

For a slip from its stress maximum (t_max) to the following minimum (t_min), from the
positions at both (fix bk/slips), each contact's first break after the maximum (fix bk/slips
``breaks``) and the energy ledger at both samples (fix bk/stress ``energy``):

- size: ``n_slipped`` particles whose x moved forward by more than S_x, ``breaks`` contacts
  broken, ``potency`` the sum of their slips (lattice units, l^3 with the cell l^2), their
  ``slip_mean`` and ``slip_max``;
- shape: ``n_clusters`` slip clusters (bkflow.clusters), the largest one's particles
  ``cluster_n``, lattice columns and rows ``cluster_nx``, ``cluster_ny``, extents
  ``cluster_lx``, ``cluster_ly``;
- ``nucleation_x``, ``nucleation_y``: the lattice site (column, row) of the first contact to
  break (ties, several contacts breaking in the same first step: the lowest atom ID), at
  ``t_nucleation``; ``front_speed``: the rupture front's
  mean speed away from it, the least-squares slope through the origin of each later-breaking
  contact's distance from the site (minimum image, lattice units) against its delay;
- energy over the slip: ``bond_released``, ``drive_released``, ``contact_released``
  (elastic energy at t_max minus at t_min), ``kinetic_gain``, ``plate_work``,
  ``dissipated_breaks``, ``dissipated_damping``, and ``energy_closure``, the balance's
  residual over the slip relative to the energy dissipated in it.

Energies are in k_d l^2 (the model's units), times in sqrt(m/k_d), speeds in l sqrt(k_d/m).
The paper's energy argument (its Eq. 2) gets, per slip cluster, the bond energy change of the
bonds that touch it and the estimate from its n_x, n_y and mean slip (``eq2_estimate``).
"""

from __future__ import annotations

import numpy as np

from . import clusters, order

#: the catalogue's columns after events.csv's own, by what the scene recorded
SIZE_COLUMNS = ("n_slipped", "potency", "slip_mean", "slip_max", "n_clusters", "cluster_n",
                "cluster_nx", "cluster_ny", "cluster_lx", "cluster_ly")
BREAK_COLUMNS = ("breaks", "nucleation_x", "nucleation_y", "t_nucleation", "front_speed")
ENERGY_COLUMNS = ("bond_released", "drive_released", "contact_released", "kinetic_gain",
                  "plate_work", "dissipated_breaks", "dissipated_damping", "energy_closure")
#: columns that hold counts or lattice indices (integers; missing where the slip has no frames)
COUNT_COLUMNS = ("n_slipped", "n_clusters", "cluster_n", "cluster_nx", "cluster_ny", "breaks",
                 "nucleation_x", "nucleation_y")


def _minimum_image(d, box):
    box = np.asarray(box, float)
    return d - box * np.round(d / box)


def nucleation_and_front(first_break, sites, box, dt: float, within=None):
    """(nucleation_x, nucleation_y, t_nucleation, front_speed) of one slip from each contact's
    first-break step ``first_break`` (N,) (-1: did not break), the lattice ``sites`` (N, 2) and
    the ``box``; NaN where no contact broke (speed: where none broke after the first).
    ``within`` (N,) bool: the contacts of the slip (its slipping particles); the others' breaks
    (a creeping layer's background) are left out."""
    brk = np.asarray(first_break, float)
    if within is not None:
        brk = np.where(np.asarray(within, bool), brk, -1.0)
    broke = np.flatnonzero(brk >= 0)
    if len(broke) == 0:
        return (np.nan,) * 4
    first = broke[np.argmin(brk[broke])]  # argmin takes the lowest index among ties
    sites = np.asarray(sites, float)
    later = broke[brk[broke] > brk[first]]
    speed = np.nan
    if len(later):
        d = np.hypot(*_minimum_image(sites[later] - sites[first], box).T)
        tau = (brk[later] - brk[first]) * dt
        speed = float((d * tau).sum() / (tau * tau).sum())
    # the site as (column, row): lattice positions are (ix + 1/2, iy + 1/2)
    return (float(np.floor(sites[first, 0])), float(np.floor(sites[first, 1])),
            float(brk[first] * dt), speed)


def cluster_sides(members, sites) -> tuple[int, int]:
    """(n_x, n_y): the lattice columns and rows a cluster's sites occupy."""
    s = np.floor(np.asarray(sites, float)[members]).astype(int)
    return len(np.unique(s[:, 0])), len(np.unique(s[:, 1]))


def eq2_estimate(k_b: float, n_x, n_y, delta, Lx: int, Ly: int, spacing: float = 1.0):
    """The paper's Eq. 2: the energy in the perimeter bonds of an n_x by n_y cluster slipping
    rigidly by delta, k_b n_y delta^2 Theta(Lx - n_x l) + k_b n_x ((delta^2 + l^2)^(1/2) -
    l)^2 Theta(Ly - n_y l) (a side as long as the box has no perimeter)."""
    n_x, n_y, delta = (np.asarray(a, float) for a in (n_x, n_y, delta))
    sp = spacing  # the lattice spacing l
    across = np.where(n_x * sp < Lx, k_b * n_y * delta ** 2, 0.0)
    along = np.where(n_y * sp < Ly, k_b * n_x * (np.sqrt(delta ** 2 + sp * sp) - sp) ** 2, 0.0)
    return across + along


def bond_energies(positions, bonds, shifts, k_b: float, r0: float = 1.0) -> np.ndarray:
    """k_b/2 (r - r0)^2 of every bond at its fixed lattice image, for one frame (N, 2)."""
    d = order.bond_vectors(positions, bonds, shifts=shifts)
    r = np.hypot(d[:, 0], d[:, 1])
    return 0.5 * k_b * (r - r0) ** 2


def slip_row(x_max, x_min, lattice, s_x: float, k_b: float, shifts=None):
    """The size and shape columns of one slip (``SIZE_COLUMNS``) from the unwrapped positions
    (N, 2) at its maximum and minimum (and ``slipping``, the mask of its slipping particles),
    and the columns of its slip clusters of two or more
    particles (label, n_c, l_x, l_y, n_x, n_y, slip: the mean slip delta, bond_change: the
    bond energy at the minimum minus at the maximum of the bonds touching the cluster,
    eq2_estimate: Eq. 2 from n_x, n_y, delta)."""
    x_max, x_min = np.asarray(x_max, float), np.asarray(x_min, float)
    slip = x_min[:, 0] - x_max[:, 0]
    mask = clusters.slipping(x_max[:, 0], x_min[:, 0], s_x)
    labels = clusters.slip_clusters(mask, lattice.bonds)
    ext = clusters.cluster_extents(x_max, labels, lattice.box)
    row = {"slipping": mask, "n_slipped": int(mask.sum()), "potency": float(slip[mask].sum()),
           "slip_mean": float(slip[mask].mean()) if mask.any() else np.nan,
           "slip_max": float(slip[mask].max()) if mask.any() else np.nan,
           "n_clusters": len(ext.n_c)}
    per = {"label": [], "n_c": [], "l_x": [], "l_y": [], "n_x": [], "n_y": [], "slip": [],
           "bond_change": [], "eq2_estimate": []}
    if shifts is None:
        shifts = order.lattice_shifts(lattice.positions, lattice.bonds, lattice.box)
    change = None
    if len(ext.label):
        change = bond_energies(x_min, lattice.bonds, shifts, k_b) \
            - bond_energies(x_max, lattice.bonds, shifts, k_b)
    ends = labels[lattice.bonds]  # (Nb, 2): the clusters of each bond's ends
    for k, c in enumerate(ext.label):  # the clusters of two or more particles
        members = np.flatnonzero(labels == c)
        nx, ny = cluster_sides(members, lattice.positions)
        touch = (ends == c).any(axis=1)
        delta = float(slip[members].mean())
        per["label"].append(int(c))
        per["n_c"].append(len(members))
        per["l_x"].append(float(ext.l_x[k]))
        per["l_y"].append(float(ext.l_y[k]))
        per["n_x"].append(nx)
        per["n_y"].append(ny)
        per["slip"].append(delta)
        per["bond_change"].append(float(change[touch].sum()))
        per["eq2_estimate"].append(float(eq2_estimate(k_b, nx, ny, delta, lattice.Lx,
                                                      lattice.Ly)))
    if len(ext.n_c):
        big = int(np.argmax(ext.n_c))
        row.update(cluster_n=int(ext.n_c[big]), cluster_nx=per["n_x"][big],
                   cluster_ny=per["n_y"][big], cluster_lx=float(ext.l_x[big]),
                   cluster_ly=float(ext.l_y[big]))
    else:
        row.update(cluster_n=0, cluster_nx=0, cluster_ny=0, cluster_lx=np.nan,
                   cluster_ly=np.nan)
    return row, per


#: the elastic and kinetic energies of a ledger (the names of bkflow.rundir.LEDGER_COLUMNS and
#: of fix bk/substrate's slots, bkflow.deck.LEDGER_SLOTS)
ENERGIES = ("e_bond", "e_drive", "e_contact", "e_kinetic")


def balance(a, b):
    """(residual, plate work, dissipation) of the energy balance between two ledgers ``a`` and
    ``b`` (mappings of ENERGIES, work, diss_break, diss_damp; scalars or arrays):
    residual = plate work - change of elastic and kinetic energy - dissipation."""
    work = b["work"] - a["work"]
    dissipated = (b["diss_break"] - a["diss_break"]) + (b["diss_damp"] - a["diss_damp"])
    change = sum(b[e] for e in ENERGIES) - sum(a[e] for e in ENERGIES)
    return work - change - dissipated, work, dissipated


def energy_rows(ledger: dict, i_max, i_min) -> dict:
    """The energy columns (``ENERGY_COLUMNS``) and ``breaks`` of every slip, from the ledger
    series (bkflow.rundir.RunDir.read_ledger) at the samples of its maximum and minimum."""
    a, b = np.asarray(i_max, int), np.asarray(i_min, int)
    L = {k: np.asarray(v, float) for k, v in ledger.items()}
    out = {"breaks": L["breaks"][b] - L["breaks"][a]}
    for name, key in (("bond_released", "e_bond"), ("drive_released", "e_drive"),
                      ("contact_released", "e_contact")):
        out[name] = L[key][a] - L[key][b]
    out["kinetic_gain"] = L["e_kinetic"][b] - L["e_kinetic"][a]
    out["plate_work"] = L["work"][b] - L["work"][a]
    out["dissipated_breaks"] = L["diss_break"][b] - L["diss_break"][a]
    out["dissipated_damping"] = L["diss_damp"][b] - L["diss_damp"][a]
    residual, _, dissipated = balance({k: v[a] for k, v in L.items()},
                                      {k: v[b] for k, v in L.items()})
    with np.errstate(invalid="ignore", divide="ignore"):
        out["energy_closure"] = np.where(dissipated > 0, residual / dissipated, np.nan)
    return out


def ledger_residual(ledger: dict, t0: float) -> float:
    """The balance's relative closure over the analysed run (t >= t0): (plate work - change of
    elastic and kinetic energy - dissipation) / plate work, from the ledger series."""
    t = np.asarray(ledger["t"], float)
    k = np.flatnonzero(t >= t0)
    if len(k) < 2:
        return float("nan")
    residual, work, _ = balance({c: float(v[k[0]]) for c, v in ledger.items()},
                                {c: float(v[k[-1]]) for c, v in ledger.items()})
    return residual / work if work > 0 else float("nan")


def typed(table):
    """A catalogue (dict of columns or DataFrame) with its count columns as pandas's nullable
    integers (missing where a slip has no frames) and ``late``/``large`` as booleans."""
    import pandas as pd

    df = table.copy() if isinstance(table, pd.DataFrame) else pd.DataFrame(table)
    for c in COUNT_COLUMNS:
        if c in df:
            v = df[c].to_numpy(float)
            v = np.where(np.isfinite(v), np.round(v), np.nan)  # inf is no count: missing
            df[c] = pd.array(v, dtype="Float64").astype("Int64")
    for c in ("late", "large"):
        if c in df:  # missing stays missing (pandas's nullable boolean)
            df[c] = pd.array(df[c].to_numpy(float), dtype="Float64").astype("boolean")
    return df
