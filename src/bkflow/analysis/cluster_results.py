"""The slip clusters of one run after its transient, as ``ClusterResult``: from the slips'
frames (fix bk/slips positions at each slip's maximum and minimum) or from the rows the run
computed itself (fix bk/slips ``catalogue``): their shapes, regimes, the event catalogue's
columns and the power law of the potencies."""

from __future__ import annotations

import dataclasses

import numpy as np

from bkflow.analysis.run_results import ClusterResult
from bkflow.model.lattice import square_lattice
from bkflow.model.params import S_X, RunSpec
from bkflow.model.settings import AnalysisSettings
from bkflow.observables import (
    catalogue,
    clusters,
    order,
    stress,
)
from bkflow.store.errors import AnalysisError, DamagedRunError
from bkflow.store.layout import SLIPS


def cluster_result(spec: RunSpec, settings: AnalysisSettings, events: stress.SlipEvents,
                   t_transient: float, steps, positions, psi_inf: float,
                   large=None, breaks=None) -> ClusterResult:
    """Clusters of every slip after the transient whose frames (maximum, minimum) fix
    bk/slips wrote; frames are matched to events by step. ``large`` (per event): which slips
    are large, for the shape of their clusters alone. ``breaks`` (frames, N): each contact's
    first break in the slip (fix bk/slips ``breaks``), for the nucleation site and the
    front's speed. Also the event catalogue's columns of those slips
    (bkflow.observables.catalogue)."""
    steps = np.asarray(steps)
    if len(steps) % 2:
        raise ValueError(f"slip snapshots come in pairs (maximum, minimum); got "
                         f"{len(steps)} frames: the file is truncated")
    lat = square_lattice(spec.Lx, spec.Ly)
    shifts = order.lattice_shifts(lat.positions, lat.bonds, lat.box)
    rows = {"event": [], "t": [], "n_c": [], "l_x": [], "l_y": [], "n_x": [], "n_y": [],
            "slip": [], "bond_change": [], "eq2_estimate": []}
    with_breaks = spec.writes_energy
    if with_breaks and breaks is None and len(steps):
        raise DamagedRunError(f"{SLIPS} has no column brk, which the scene writes: the file is "
                              "damaged; run the run again")
    columns = catalogue.SIZE_COLUMNS + (catalogue.BREAK_COLUMNS[1:] if with_breaks else ())
    table = {c: np.full(len(events), np.nan) for c in columns}
    pairs, evs = _slips_of_frames(spec, events, t_transient, steps,
                                  breaks if with_breaks else None)
    matched = len(pairs)
    if matched:  # every slip at once (catalogue.slip_rows)
        k = np.asarray(pairs)
        slips_, per = catalogue.slip_rows(np.asarray(positions)[k], np.asarray(positions)[k + 1],
                                          lat, settings.s_x, spec.k_b, shifts)
        ev = np.asarray(evs)
        for c in catalogue.SIZE_COLUMNS:
            table[c][ev] = slips_[c]
        if with_breaks:
            for j, (kk, e) in enumerate(zip(pairs, evs)):
                found = catalogue.nucleation_and_front(breaks[kk + 1], lat.positions, lat.box,
                                                       spec.dt, slips_["slipping"][j])
                for c, v in zip(catalogue.BREAK_COLUMNS[1:], found):
                    table[c][e] = v
        at = per.pop("slip_index")
        rows["event"] = ev[at].tolist()
        rows["t"] = events.t_max[ev[at]].astype(float).tolist()
        for c in rows:
            if c not in ("event", "t"):
                rows[c] = np.asarray(per[c]).tolist()
    return _cluster_summary(spec, settings, events, t_transient, rows, table, matched, psi_inf,
                            large)


def _slips_of_frames(spec: RunSpec, events: stress.SlipEvents, t_transient: float, steps,
                     breaks=None) -> tuple[list[int], list[int]]:
    """(the first frame of each pair that is a slip of this analysis after the transient, its
    event): pairs whose maximum is an event's and whose minimum is that event's too (a slip
    recorded at another threshold ends elsewhere: its frames are not this slip's). With
    ``breaks``, each pair's first breaks are checked to fall inside it."""
    # events of stress.csv by step: sample k of stress.csv is step k * stress_nevery
    index = {int(i) * spec.stress_nevery: k for k, i in enumerate(events.i_max)}
    pairs, evs = [], []
    for k in range(0, len(steps), 2):
        ev = index.get(int(steps[k]))
        if ev is None or events.t_max[ev] < t_transient:
            continue
        if int(steps[k + 1]) != int(events.i_min[ev]) * spec.stress_nevery:
            continue
        if breaks is not None:
            b = breaks[k + 1]
            if ((b != -1) & ((b <= steps[k]) | (b > steps[k + 1]))).any() or \
                    not np.isfinite(b).all():
                raise DamagedRunError(
                    f"{SLIPS}: a first break (column brk) outside its slip, steps "
                    f"{int(steps[k])}..{int(steps[k + 1])}: the file is damaged; run the run "
                    "again")
        pairs.append(k)
        evs.append(ev)
    return pairs, evs


def _cluster_summary(spec: RunSpec, settings: AnalysisSettings, events: stress.SlipEvents,
                     t_transient: float, rows: dict, table: dict, matched: int,
                     psi_inf: float, large=None) -> ClusterResult:
    """The clusters' shape (all, and the large slips'), the potencies' power law, from the
    clusters' rows and the catalogue's columns of every event."""
    box = (float(spec.Lx), float(spec.Ly))
    shape = clusters.cluster_shape(rows["l_x"], rows["l_y"], box, psi_inf,
                                   settings.span_fraction, settings.psi_crystal)
    big = np.zeros(len(rows["event"]), bool) if large is None else \
        np.asarray(large, bool)[np.asarray(rows["event"], dtype=int)]
    shape_large = clusters.cluster_shape(np.asarray(rows["l_x"])[big],
                                         np.asarray(rows["l_y"])[big], box, psi_inf,
                                         settings.span_fraction, settings.psi_crystal)
    n_late = int(np.sum(events.t_max >= t_transient))
    potency = table["potency"][np.isfinite(table["potency"])]
    test = stress.power_law_test(potency[potency > 0])
    return ClusterResult(rows, shape, matched, n_late - matched, shape_large, table, test)


#: the clusters' columns of clusters.csv after event and t, as the run's rows name them
CLUSTER_ROW_COLUMNS = ("n_c", "l_x", "l_y", "n_x", "n_y", "slip", "bond_change",
                       "eq2_estimate")


def cluster_from_rows(spec: RunSpec, settings: AnalysisSettings, events: stress.SlipEvents,
                      t_transient: float, slip_rows, cluster_rows, psi_inf: float,
                      large=None) -> ClusterResult:
    """``cluster_result`` from what the run computed of each slip (fix bk/slips
    ``catalogue``, scene figures: slips.npy and clusters.npy, at s_x = S_X): rows matched
    to the events by the steps of their maximum and minimum, as frames are."""
    if settings.s_x != S_X:
        raise AnalysisError(f"the run computed its slips' clusters at s_x = {S_X:g} (scene "
                            f"figures); s_x = {settings.s_x:g} needs the positions at each "
                            "slip (scene clusters, events or full)")
    nevery = spec.stress_nevery
    ev_max = np.asarray(events.i_max, np.int64) * nevery   # increasing, as the slips come
    ev_min = np.asarray(events.i_min, np.int64) * nevery
    smax = np.asarray(slip_rows["step_max"], np.int64)
    smin = np.asarray(slip_rows["step_min"], np.int64)
    table = {c: np.full(len(events), np.nan) for c in catalogue.SIZE_COLUMNS}
    if len(events):
        at = np.minimum(np.searchsorted(ev_max, smax), len(events) - 1)
        # a row of another threshold than this analysis's matches no slip of its own
        ok = (ev_max[at] == smax) & (ev_min[at] == smin) & \
            (np.asarray(events.t_max)[at] >= t_transient)
    else:
        at, ok = np.zeros(len(smax), np.int64), np.zeros(len(smax), bool)
    for c in catalogue.SIZE_COLUMNS:
        table[c][at[ok]] = np.asarray(slip_rows[c], float)[ok]
    matched, first = np.unique(smax[ok], return_index=True)
    cstep = np.asarray(cluster_rows["step_max"], np.int64)
    keep = np.isin(cstep, matched)
    ev_of = at[ok][first][np.searchsorted(matched, cstep[keep])].astype(np.int64)
    rows = {"event": ev_of.tolist(), "t": events.t_max[ev_of].astype(float).tolist()}
    for c in CLUSTER_ROW_COLUMNS:
        rows[c] = np.asarray(cluster_rows[c][keep]).tolist()
    return dataclasses.replace(
        _cluster_summary(spec, settings, events, t_transient, rows, table, len(matched),
                         psi_inf, large), recorded=True)
