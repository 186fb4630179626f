"""The event catalogue: one row per slip, with its size, shape, nucleation site, rupture front
and energy budget (docs/model.md "Energy"; the scenes events and full record what it needs).

For a slip from its stress maximum (t_max) to the following minimum (t_min), from the
positions at both (fix bk/slips), each contact's first break after the maximum (fix bk/slips
``breaks``) and the energy ledger at both samples (fix bk/stress ``energy``):

- size: ``n_slipped`` particles whose x moved forward by more than S_x, ``breaks`` contacts
  broken, ``potency`` the sum of their slips (lattice units, l^3 with the cell l^2), their
  ``slip_mean`` and ``slip_max``;
- shape: ``n_clusters`` slip clusters (bkflow.observables.clusters), the largest one's particles
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

#: the catalogue's columns after events.parquet's own, by what the scene recorded
from bkflow.observables import clusters, order

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


def _components(mask, bonds) -> np.ndarray:
    """Per slip and particle (S, N), the smallest particle index of its connected component
    through the bonds joining two slipping particles (-1: not slipping), all slips at once:
    minima passed along the bonds, then each label replaced by its own label (pointer
    jumping), until nothing changes."""
    S, N = mask.shape
    bi, bj = np.asarray(bonds)[:, 0], np.asarray(bonds)[:, 1]
    big = np.int64(N)
    lab = np.where(mask, np.arange(N, dtype=np.int64)[None, :], big)
    active = mask[:, bi] & mask[:, bj]
    rows = np.broadcast_to(np.arange(S)[:, None], active.shape)[active]
    ii, jj = np.broadcast_to(bi, active.shape)[active], np.broadcast_to(bj, active.shape)[active]
    flat = lab.reshape(-1)
    while True:
        m = np.minimum(flat[rows * N + ii], flat[rows * N + jj])
        before = flat.copy()
        np.minimum.at(flat, rows * N + ii, m)
        np.minimum.at(flat, rows * N + jj, m)
        inside = flat < big
        idx = np.flatnonzero(inside)
        flat[idx] = flat[(idx // N) * N + flat[idx]]   # jump to the label's own label
        if np.array_equal(flat, before):
            break
    lab = flat.reshape(S, N)
    return np.where(mask, lab, -1)


def slip_rows(x_max, x_min, lattice, s_x: float, k_b: float, shifts=None):
    """``slip_row`` of many slips at once, vectorised over the slips: positions (S, N, 2) at
    their maxima and minima. Returns (rows: the size and shape columns, arrays of S, with
    ``slipping`` (S, N); clusters: the columns of every cluster of two or more particles, in
    slip then label order, with ``slip_index``), the same numbers as ``slip_row`` on each slip
    (its sums in another order: to rounding)."""
    x_max, x_min = np.asarray(x_max, float), np.asarray(x_min, float)
    S, N = x_max.shape[:2]
    Lx, Ly = float(lattice.box[0]), float(lattice.box[1])
    slip = x_min[:, :, 0] - x_max[:, :, 0]
    mask = slip > s_x
    root = _components(mask, lattice.bonds)
    # clusters numbered in slip order, then by their first particle (slip_clusters' order)
    sel = np.flatnonzero(mask.reshape(-1))
    slip_of = sel // N
    key = slip_of * N + root.reshape(-1)[sel]
    uniq, cid = np.unique(key, return_inverse=True)
    n_c = np.bincount(cid, minlength=len(uniq))
    c_slip = uniq // N
    keep = n_c >= 2
    # the extents: sum over unordered pairs of minimum-image distances, per cluster, from
    # coordinates sorted within each cluster and prefix sums (clusters.periodic_pair_sum)
    onset = x_max.reshape(S * N, 2)[sel]

    def pair_sums(coord, length):
        x = np.mod(coord, length)
        span = 2 * length + 1
        order_ = np.lexsort((x, cid))
        xs, cs = x[order_], cid[order_]
        keys = cs * span + xs
        start = np.searchsorted(cs, np.arange(len(uniq)))
        end = np.append(start[1:], len(cs))
        seg_end = end[cs]
        prefix = np.concatenate([[0.0], np.cumsum(xs)])
        i = np.arange(len(xs))
        h = np.searchsorted(keys, keys + 0.5 * length, side="right")
        h = np.minimum(np.maximum(h, i + 1), seg_end)
        near = (prefix[h] - prefix[i + 1]) - (h - (i + 1)) * xs
        far = (seg_end - h) * (length + xs) - (prefix[seg_end] - prefix[h])
        return np.bincount(cs, near + far, minlength=len(uniq))

    pairs = n_c * (n_c - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        l_x = np.where(n_c >= 2, 8.0 * pair_sums(onset[:, 0], Lx) / pairs, np.nan)
        l_y = np.where(n_c >= 2, 8.0 * pair_sums(onset[:, 1], Ly) / pairs, np.nan)
    # columns and rows each cluster's lattice sites occupy
    site = np.floor(np.asarray(lattice.positions, float)).astype(np.int64)[sel % N]
    nx = np.bincount(np.unique(cid * (int(Lx) + 1) + site[:, 0]) // (int(Lx) + 1),
                     minlength=len(uniq))
    ny = np.bincount(np.unique(cid * (int(Ly) + 1) + site[:, 1]) // (int(Ly) + 1),
                     minlength=len(uniq))
    delta = np.bincount(cid, slip.reshape(-1)[sel], minlength=len(uniq)) / n_c
    # the bond energy change of the bonds touching each cluster
    if shifts is None:
        shifts = order.lattice_shifts(lattice.positions, lattice.bonds, lattice.box)
    def energies(x):                                                   # (S, Nb)
        d = order.bond_vectors(x, lattice.bonds, shifts=shifts)
        return 0.5 * k_b * (np.hypot(d[..., 0], d[..., 1]) - 1.0) ** 2

    change = energies(x_min) - energies(x_max)
    c_of = np.full(S * N, -1, dtype=np.int64)
    c_of[sel] = cid
    bonds = np.asarray(lattice.bonds)
    ends = c_of.reshape(S, N)[:, bonds]                                # (S, Nb, 2)
    a, b = ends[..., 0], ends[..., 1]
    touch = np.zeros(len(uniq))
    np.add.at(touch, a[a >= 0], change[a >= 0])
    other = (b >= 0) & (b != a)
    np.add.at(touch, b[other], change[other])
    # per slip
    rows = {"slipping": mask, "n_slipped": mask.sum(axis=1),
            "potency": np.where(mask, slip, 0.0).sum(axis=1)}
    with np.errstate(invalid="ignore"):
        rows["slip_mean"] = np.where(rows["n_slipped"] > 0,
                                     rows["potency"] / np.maximum(rows["n_slipped"], 1), np.nan)
    rows["slip_max"] = np.where(rows["n_slipped"] > 0,
                                np.where(mask, slip, -np.inf).max(axis=1), np.nan)
    rows["n_clusters"] = np.bincount(c_slip[keep], minlength=S)
    # the largest cluster of each slip (the first of equal ones, in label order)
    big = np.full(S, -1)
    kept = np.flatnonzero(keep)
    ranked = kept[np.lexsort((kept, -n_c[kept], c_slip[kept]))]
    firsts = np.unique(c_slip[ranked], return_index=True)[1]
    big[c_slip[ranked[firsts]]] = ranked[firsts]
    has = big >= 0
    rows["cluster_n"] = np.where(has, n_c[big], 0)
    rows["cluster_nx"] = np.where(has, nx[big], 0)
    rows["cluster_ny"] = np.where(has, ny[big], 0)
    rows["cluster_lx"] = np.where(has, l_x[big], np.nan)
    rows["cluster_ly"] = np.where(has, l_y[big], np.nan)
    first_of = np.searchsorted(c_slip, np.arange(S))    # each slip's first cluster
    per = {"slip_index": c_slip[keep],
           "label": (np.arange(len(uniq)) - first_of[c_slip])[keep],
           "n_c": n_c[keep], "l_x": l_x[keep], "l_y": l_y[keep], "n_x": nx[keep],
           "n_y": ny[keep], "slip": delta[keep], "bond_change": touch[keep],
           "eq2_estimate": eq2_estimate(k_b, nx[keep], ny[keep], delta[keep], lattice.Lx,
                                        lattice.Ly)}
    return rows, per


#: the elastic and kinetic energies of a ledger (the names of bkflow.store.rundir.LEDGER_COLUMNS and
#: of fix bk/substrate's slots, bkflow.lammps.deck.LEDGER_SLOTS)
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
    series (bkflow.store.rundir.RunDir.read_ledger) at the samples of its maximum and minimum."""
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
