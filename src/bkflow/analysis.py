"""One run's outputs turned into its summary: mu_bar, Psi(inf), cluster shapes, regime.

:func:`summarize` is pure (arrays in, a dict and tables out); :func:`analyze` reads a run
directory through :mod:`bkflow.io` and writes ``summary.json``, ``psi.csv`` and
``clusters.csv`` next to the run's files. The observables are those of MODEL.md
("Observables"); every threshold used is written into the summary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__, clusters, order, stress
from .lattice import square_lattice
from .params import RunSpec


@dataclass(frozen=True)
class AnalysisSettings:
    """Analysis choices MODEL.md leaves open (each one is reported in summary.json)."""

    s_x: float = clusters.DEFAULT_S_X
    span_fraction: float = clusters.DEFAULT_SPAN_FRACTION
    psi_crystal: float = clusters.DEFAULT_PSI_CRYSTAL
    psi_late_fraction: float = order.DEFAULT_LATE_FRACTION
    report_thresholds: tuple = stress.REPORT_THRESHOLDS
    #: lower cut of the stress-drop power law, as a multiple of the slip threshold (the
    #: smallest drop that counts as a slip); None = chosen by the KS rule of Clauset et al.
    drop_x_min_over_threshold: float | None = 1.0


@dataclass
class RunAnalysis:
    """What :func:`summarize` returns: the summary row and the per-run tables."""

    summary: dict
    psi: dict | None = None          # columns t, psi
    clusters: dict | None = None     # columns event, t, n_c, l_x, l_y


def _key(fraction: float) -> str:
    return f"{fraction:g}"


def summarize(spec: RunSpec, t, sigma, snapshots=None, slip_frames=None,
              settings: AnalysisSettings = AnalysisSettings()) -> RunAnalysis:
    """Summary of one run.

    ``t``, ``sigma``: the stress series (stress.csv). ``snapshots``: (steps (F,), unwrapped
    positions (F, N, 2)) of the order scene, or None. ``slip_frames``: (steps, positions) of
    fix bk/slips, frames in pairs (maximum, minimum), or None.
    """
    t = np.asarray(t, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    dt = spec.dt
    t_transient = spec.transient_step * dt
    thr = spec.slip_threshold_stress
    fr = stress.friction(t, sigma, spec.sigma_n, thr, t_transient=t_transient)
    events = fr.events
    late = events.after(t_transient)
    x_min = (None if settings.drop_x_min_over_threshold is None
             else settings.drop_x_min_over_threshold * thr)
    fit = stress.power_law_fit(late.drop, x_min=x_min)

    by_thr, err_thr, n_thr = {}, {}, {}
    for f in settings.report_thresholds:
        ff = stress.friction(t, sigma, spec.sigma_n, f * spec.mu_s * spec.sigma_n,
                             t_transient=t_transient)
        by_thr[_key(f)], err_thr[_key(f)], n_thr[_key(f)] = ff.mu_bar, ff.mu_bar_err, ff.n_slips

    summary = {
        "bkflow": __version__,
        **{k: v for k, v in spec.to_dict().items()},
        "N": spec.N,
        "mu_bar": fr.mu_bar,
        "mu_bar_err": fr.mu_bar_err,
        "mu_bar_err_method": "blocking over successive slips (Flyvbjerg-Petersen levels, "
                             "level chosen by Jonsson 2018)",
        "mu_bar_err_reliable": fr.error_reliable,
        "n_slips": fr.n_slips,
        "mean_stress_ratio": fr.mean_stress_ratio,
        "mu_bar_by_threshold": by_thr,
        "mu_bar_err_by_threshold": err_thr,
        "n_slips_by_threshold": n_thr,
        "slip_threshold_stress": thr,
        "t_transient": t_transient,
        "drop_exponent": fit.alpha,
        "drop_exponent_err": fit.alpha_err,
        "drop_x_min": fit.x_min,
        "drop_n_tail": fit.n_tail,
        "drop_ks": fit.ks,
        "drop_fit": "continuous power-law maximum likelihood above x_min, Clauset, Shalizi and "
                    "Newman, SIAM Rev. 51, 661 (2009), Eq. 3.1; x_min = the slip threshold "
                    "unless set (None: their KS rule); drop_ks = KS distance of the fit",
        "s_x": settings.s_x,
        "span_fraction": settings.span_fraction,
        "psi_crystal": settings.psi_crystal,
        "psi_late_fraction": settings.psi_late_fraction,
        "psi_inf": math.nan,
        "lx_mean_over_Lx": math.nan,
        "ly_mean_over_Ly": math.nan,
        "lx_over_ly": math.nan,
        "n_clusters": None,
        "n_cluster_events": None,
        "regime": None,
    }
    result = RunAnalysis(summary)
    lat = square_lattice(spec.Lx, spec.Ly)

    if snapshots is not None:
        steps, pos = snapshots
        shifts = order.lattice_shifts(lat.positions, lat.bonds, lat.box)
        ts = np.asarray(steps) * dt
        p = order.psi(order.bond_vectors(pos, lat.bonds, shifts=shifts), lat.bonds, spec.N)
        summary["psi_inf"] = order.psi_inf(ts, p, settings.psi_late_fraction)
        result.psi = {"t": ts, "psi": p}

    if slip_frames is not None:
        steps, pos = slip_frames
        steps = np.asarray(steps)
        if len(steps) % 2:
            raise ValueError(f"slip snapshots come in pairs (maximum, minimum); got "
                             f"{len(steps)} frames: the file is truncated")
        # events of stress.csv by step: sample k of stress.csv is step k * stress_nevery
        index = {int(i) * spec.stress_nevery: k for k, i in enumerate(events.i_max)}
        rows = {"event": [], "t": [], "n_c": [], "l_x": [], "l_y": []}
        matched = 0
        for k in range(0, len(steps), 2):
            ev = index.get(int(steps[k]))
            if ev is None or events.t_max[ev] < t_transient:
                continue
            matched += 1
            ext = clusters.event_clusters(pos[k], pos[k + 1], lat.bonds, lat.box, settings.s_x)
            rows["event"] += [ev] * len(ext)
            rows["t"] += [float(events.t_max[ev])] * len(ext)
            rows["n_c"] += ext.n_c.tolist()
            rows["l_x"] += ext.l_x.tolist()
            rows["l_y"] += ext.l_y.tolist()
        shape = clusters.cluster_shape(rows["l_x"], rows["l_y"], lat.box, summary["psi_inf"],
                                       settings.span_fraction, settings.psi_crystal)
        summary.update({
            "lx_mean_over_Lx": shape.lx_mean_over_Lx,
            "ly_mean_over_Ly": shape.ly_mean_over_Ly,
            "lx_over_ly": shape.lx_over_ly,
            "n_clusters": shape.n_clusters,
            "n_cluster_events": matched,
            "n_slips_without_snapshots": len(late) - matched,
            "regime": shape.regime,
            "regime_fractions": shape.regime_fractions,
        })
        result.clusters = rows
    return result


def analyze(run_dir, settings: AnalysisSettings = AnalysisSettings()) -> dict:
    """Analyse a finished run directory: write summary.json (and psi.csv, clusters.csv when
    the scene recorded them); return the summary as written (None where not measured).

    The directory is a ``bkflow run`` output (meta.json) or a deck run standalone with
    ``lmp -in in.bk`` (params.json from ``bkflow deck``, finished when stress.csv reaches
    t_end)."""
    from . import io
    from .deck import PARAMS_FILE, SLIPS_FILE, SNAPSHOT_FILE, STRESS_FILE
    from .engine import CLUSTERS_FILE, META_FILE, PSI_FILE, SUMMARY_FILE, is_complete

    d = Path(run_dir)
    if not d.is_dir():
        raise FileNotFoundError(f"{d} is not a directory")
    if is_complete(d):
        meta = io.read_json(d / META_FILE)
        spec = RunSpec.from_dict(meta["params"])
        t, sigma = io.read_stress(d / STRESS_FILE)
    elif (d / PARAMS_FILE).exists() and (d / STRESS_FILE).exists():
        # a deck run standalone (lmp -in in.bk): finished when the series reaches t_end
        meta = {}
        spec = RunSpec.from_dict(io.read_json(d / PARAMS_FILE))
        t, sigma = io.read_stress(d / STRESS_FILE)
        last = spec.stress_nevery * (spec.n_steps // spec.stress_nevery) * spec.dt
        if len(t) == 0 or t[-1] < last - 0.5 * spec.dt:
            raise ValueError(f"{d / STRESS_FILE} ends at t = {t[-1] if len(t) else 0:g}, "
                             f"before the run's end ({last:g}): the run did not finish")
    else:
        raise ValueError(f"{d} holds no finished run (no meta.json with status complete, nor "
                         f"a deck's {PARAMS_FILE} with its {STRESS_FILE}); run it first with "
                         "bkflow run")
    snaps = slips = None
    if spec.writes_snapshots:
        f = io.read_frames(d / SNAPSHOT_FILE, spec.N)
        snaps = (f.steps, f.positions)
    if spec.writes_slips:
        f = io.read_frames(d / SLIPS_FILE, spec.N)
        slips = (f.steps, f.positions)
    res = summarize(spec, t, sigma, snaps, slips, settings)
    res.summary["run_dir"] = str(d)
    res.summary["wall_time_s"] = meta.get("wall_time_s")
    res.summary["bytes_written"] = meta.get("bytes_written")
    for name, table in ((PSI_FILE, res.psi), (CLUSTERS_FILE, res.clusters)):
        (d / name).unlink(missing_ok=True)
        if table is not None:
            io.write_table(d / name, table)
    io.write_json_atomic(d / SUMMARY_FILE, res.summary)
    return io.json_ready(res.summary)  # as written: NaN (not measured) reads back as None
