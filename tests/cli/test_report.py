"""The printed reports: the sweep's table and a run's summary lines."""

import math

import pandas as pd

from bkflow.cli import report


def _row(phi, **kw):
    row = dict(phi=phi, Lx=20, Ly=5, n_seeds=3, state="steady", mu_bar=0.1213,
               mu_bar_err=1.1e-4, mu_bar_large=0.1238, mu_bar_large_err=1.8e-4,
               mean_stress_ratio=0.1176, mean_stress_ratio_err=9.1e-5, psi_inf=math.nan,
               psi_inf_sem=math.nan, lx_over_ly=math.nan, lx_over_ly_sem=math.nan,
               regime=math.nan)
    row.update(kw)
    return row


def test_the_sweep_table_is_as_wide_as_its_cells_and_leaves_out_what_no_point_has():
    """Columns fit their widest cell; a column no point has a value in (Psi, the clusters'
    extents and regime under the friction scene) is left out, not printed as n/a rows."""
    res = pd.DataFrame([_row(0.1), _row(1000, state="quiet+coherent", n_switching=3)])
    lines = report.results_lines(res)
    assert len({len(line) for line in lines[:1]}) == 1
    head = lines[0]
    assert "Psi(inf)" not in head and "regime" not in head and "<l_x>/<l_y>" not in head
    assert "mu_bar" in head and "<sigma_x>/sigma_n" in head
    assert max(map(len, lines)) <= 100, lines
    assert "quiet+coherent 3/3" in lines[2] and "0.1213 +- 0.00011" in lines[1]
    full = pd.DataFrame([_row(0.1, psi_inf=0.567, psi_inf_sem=0.011, lx_over_ly=2.13,
                              lx_over_ly_sem=0.039, regime="DT")])
    head = report.results_lines(full)[0]
    assert "Psi(inf)" in head and "regime" in head
    # every row has the header's columns, right-aligned under them
    lines = report.results_lines(full, axes=("mu_s",)) if "mu_s" in full else \
        report.results_lines(full.assign(mu_s=0.2), axes=("mu_s",))
    assert lines[0].index("mu_s") < lines[0].index("seeds")
    assert all(len(line) <= len(lines[0]) + 8 for line in lines)


def test_a_summary_says_what_its_n_a_and_its_extents_above_one_mean(lammps, tmp_path):
    """'n/a' at a threshold no slip dropped by, and extents above 1, are said where they are
    printed, not only in docs/model.md."""
    from bkflow.analysis.summary import analyze
    from bkflow.lammps.engine import run
    from bkflow.model.params import RunSpec
    from bkflow.model.protocols import protocol_fields

    run(RunSpec(phi=10.0, scene="clusters", **protocol_fields("paper", t_end=20000.0)),
        tmp_path / "r", progress=False)
    s = analyze(tmp_path / "r")
    s["mu_bar_by_threshold"] = {**s["mu_bar_by_threshold"], "0.1": None}
    lines = report.summary_lines(s)
    by = next(line for line in lines if "by threshold" in line)
    assert "0.1: n/a" in by and "n/a: no slip dropped by that much" in by
    clusters = next(line for line in lines if line.startswith("  clusters: "))
    assert s["lx_mean_over_Lx"] > 1 and "whole-box slip's can exceed 1" in clusters


def test_sweep_init_says_what_its_jobs_cost_in_all(tmp_path, capsys):
    """bkflow sweep --init creates the jobs for a cluster without running them, and says their
    cost on one core (the cluster divides it by its cores), as a sweep does before it runs."""
    from bkflow.cli.commands import main

    assert main(["sweep", "--phi", "10,1000", "--sizes", "240x60", "--seeds", "2", "--init",
                 "--out", str(tmp_path / "g")]) == 0
    out = capsys.readouterr().out
    cost = next(line for line in out.splitlines() if line.startswith("cost:"))
    assert "atom-steps" in cost and "on 1 core(s)" in cost and "on disk" in cost
    assert "4 jobs (0 finished)" in out
