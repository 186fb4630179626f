"""The blocks of RESULTS.md's "Speed" (and REPRODUCTION.md's cost of the largest grid): the main
command and the test suite (benchmarks/records/readme_numbers.json), the fixed cost of a run,
what a scene writes and costs, and the fused path on many ranks.
"""

from __future__ import annotations

from benchmarks.documents.cells import readme_record, record


def _sweep_wall(h: dict) -> float:
    """A measurement's wall time of the main command as README.md states it: for the current
    one (the record's ``sweep``), the time its printed output gives, where
    benchmarks/documents/readme_numbers.py reads one (``printed_wall``); else the measured
    ``wall_s``."""
    from benchmarks.documents.readme_numbers import printed_wall

    s = readme_record().get("sweep") or {}
    if s.get("output") and h.get("commit") == s.get("commit") \
            and h.get("bytes") == s.get("bytes"):
        wall = printed_wall(s["output"])
        if wall is not None:
            return wall
    return h["wall_s"]


def main_command() -> str:
    """Every measurement of the main command (benchmarks/documents/readme_numbers.py --sweep)."""
    from benchmarks.documents.readme_numbers import duration, human

    out = ["| date | commit | `bkflow sweep --phi 1e-1:1e3` | on disk | runs (pairs) | at a time |",
           "|---|---|---|---|---|---|"]
    for h in readme_record().get("sweep_history", []):
        out.append(f"| {h['date']} | {h['commit']} | {duration(_sweep_wall(h))} | "
                   f"{human(h['bytes'])} | {h['runs']} | {h['jobs']} |")
    return "\n".join(out) + "\n"


def readme_numbers() -> str:
    """The README's measured numbers as they stand (benchmarks/records/readme_numbers.json):
    the main command, the quick start and the test suite, each with the date and commit it was
    measured at."""
    from benchmarks.documents.readme_numbers import duration, human

    rec = readme_record()
    out = ["| what | command | measured | date, commit |", "|---|---|---|---|"]
    s = rec.get("sweep")
    if s:
        out.append(f"| the main command | `{s['command']}` | {duration(_sweep_wall(s))}, "
                   f"{human(s['bytes'])} on disk; {s['runs']} pairs of runs, {s['jobs']} at a "
                   f"time on {s['cores']} cores | {s.get('date', 'n/a')}, "
                   f"{s.get('commit', 'n/a')} |")
    r = rec.get("run")
    if r:
        out.append(f"| the quick start | `{r['command']}` | {duration(r['wall_s'])} the "
                   f"whole command, {human(r['bytes'])} on disk | {r.get('date', 'n/a')}, "
                   f"{r.get('commit', 'n/a')} |")
    t = rec.get("tests")
    if t:
        out.append(f"| the test suite | `pytest` (and `pytest -m \"not slow\"`) | {t['all']} "
                   f"tests in {duration(t['wall_s'])} ({t['fast']} in "
                   f"{duration(t['fast_wall_s'])}) on {t['cores']} cores, "
                   f"{'all passed' if t.get('passed') else 'not all passed'} | "
                   f"{t.get('date', 'n/a')}, {t.get('commit', 'n/a')} |")
    return "\n".join(out) + "\n"


def steady_sizes() -> str:
    """The main command's grid under the steady protocol at N = 400 and 900
    (benchmarks/documents/readme_numbers.py --sizes): time, bytes and what its runs were."""
    from benchmarks.documents.readme_numbers import duration, human

    rec = readme_record().get("sizes")
    if not rec:
        return "(not measured yet: python -m benchmarks.documents.readme_numbers --sizes)\n"
    out = ["| N | command | time | on disk | runs | their states |", "|---|---|---|---|---|---|"]
    for n, m in rec.items():
        if not isinstance(m, dict) or "wall_s" not in m:
            continue
        states = next((ln for ln in m["output"].splitlines() if " runs are steady" in ln), "")
        out.append(f"| {n} | `{m['command']}` | {duration(m['wall_s'])} | "
                   f"{human(m['bytes'])} | {m['runs']} | {states.split(';')[0]} |")
    goes = [(n, m["by_size"]) for n, m in rec.items()
            if isinstance(m, dict) and len(m.get("by_size") or {}) > 1]
    for n, by in goes:
        total = sum(v["run_s"] for v in by.values())
        out += ["", f"Where the time of `--sizes {n}` goes (the runs' LAMMPS seconds, each run "
                "and its companion, summed over both cores):", "",
                "| N | runs | seconds | share | runs to the cap | their seconds |",
                "|---|---|---|---|---|---|"]
        for size, v in by.items():
            out.append(f"| {size} | {v['runs']} | {v['run_s']:.0f} | "
                       f"{100 * v['run_s'] / total:.0f}% | {v['capped']} | "
                       f"{v['capped_s']:.0f} |")
    return "\n".join(out) + "\n"


def fixed_cost() -> str:
    """The fixed cost of a run, piece by piece (benchmarks/measure/fixed_cost.py)."""
    rec = record("fixed_cost")
    if rec is None:
        return "(not measured yet: python -m benchmarks.measure.fixed_cost)\n"
    m = rec["median_s"]
    out = ["| piece | time (median of "
           f"{rec['rounds']}, {rec['date']}) |", "|---|---|"]
    for name, t in m.items():
        shown = name + (" (inside a process that has its imports)" if name.endswith("warm")
                        else " (a whole process)")
        out.append(f"| {shown} | {t:.2f} s |")
    out.append(f"| the 8000-unit run's own simulation | {rec['simulation_8000_s']:.2f} s |")
    out.append("")
    one = m.get("run 10, one run (paper)")
    warm = m.get("analyze 8000, warm")
    sim = rec["simulation_8000_s"]
    out.append(f"A run's fixed cost (run 10 without its analysis, less the interpreter) is "
               f"{m['run 10'] - m['python']:.2f} s for the steady protocol's pair"
               + (f", {one - m['python']:.2f} s for one run" if one is not None else "")
               + f"; the analysis of an 8000-unit run takes {m['analyze 8000']:.2f} s in a "
               f"process of its own, {m['analyze 8000'] / sim:.2f}x its simulation's time"
               + (f", and {warm:.2f} s ({warm / sim:.2f}x) where the imports are paid (a "
                  "sweep's workers)" if warm is not None else "") + ".")
    return "\n".join(out) + "\n"


def scene_bytes() -> str:
    """Per size and scene: bytes per 10^5 time units, the loop against friction's, and the
    analysis against the loop (benchmarks/measure/scene_costs.py's record)."""
    from benchmarks.documents.readme_numbers import human

    rec = record("scene_bytes")
    if rec is None:
        return "(not measured yet: python -m benchmarks.measure.scene_costs)\n"
    out = []
    for size, m in sorted(rec.get("sizes", {}).items(), key=lambda kv: len(kv[0])):
        lx, ly = (int(v) for v in size.split("x"))
        out += [f"N = {lx * ly} ({size}), phi = {m['phi']:g}, `--protocol paper --t-end "
                f"{m['t_end']:g}`, default time step; median of {m['rounds']} alternated "
                "rounds:", "",
                "| scene | bytes per 10^5 time units | LAMMPS loop / friction | loop s | "
                "`bkflow analyze` s | analysis / loop |", "|---|---|---|---|---|---|"]
        for scene, r in m["scenes"].items():
            out.append(f"| {scene} | {human(r['bytes_per_1e5'])} | "
                       f"{r['loop_over_friction']:.2f}x | {r['loop_s']:.2f} | "
                       f"{r['analyze_s']:.2f} | {r['analyze_s'] / r['loop_s']:.2f} |")
        out.append("")
    if "long" in rec:
        g = rec["long"]
        out.append(f"`{g['command']}`: {human(g['bytes_written'])} written by the run, "
                   f"{human(g['with_analysis'])} with its analysis; the loop {g['loop_s']:.0f} s, "
                   f"the whole command {g['whole_s']:.0f} s.")
        out.append("")
    return "\n".join(out)


#: the commit of the main command's measurement before the runs reduced their series in the run
#: (bkflow 0.5.0): the "before" of the scene goals
BEFORE_REDUCTION = "43a0f39"
#: the scenes that record frames
FRAMES = ("clusters", "events", "fronts", "full")


def _met(ok: bool) -> str:
    return "**met**" if ok else "**not met**"


def _byte_goals(rec: dict) -> list[str]:
    """The goals of bytes and of the loop: the main command's bytes (readme_numbers.json,
    before and after), a run of 10^6 time units at phi = 1000 (scene_bytes.json ``long``), the
    costliest scene without frames against friction."""
    from benchmarks.documents.readme_numbers import duration, human

    hist = readme_record().get("sweep_history", [])
    before = next((h for h in hist if h["commit"] == BEFORE_REDUCTION), None)
    now = hist[-1] if hist else None
    no_frames = [(size, scene, r["loop_over_friction"])
                 for size, m in rec.get("sizes", {}).items()
                 for scene, r in m["scenes"].items()
                 if scene not in FRAMES and scene != "friction"]
    worst = max(no_frames, key=lambda x: x[2]) if no_frames else None
    long = rec.get("long")
    rows = []
    if before and now:
        rows.append(f"| the main command writes at most 50 MB | {human(now['bytes'])} in "
                    f"{duration(_sweep_wall(now))} (before: {human(before['bytes'])} in "
                    f"{duration(_sweep_wall(before))}) | {_met(now['bytes'] <= 50e6)} |")
    if long:
        rows.append(f"| 10^6 time units at phi = 1000 in the default scene: at most 5 MB | "
                    f"{human(long['bytes_written'])} | {_met(long['bytes_written'] <= 5e6)} |")
    if worst:
        rows.append(f"| no scene above 1.1x friction unless it records frames | the costliest "
                    f"without frames: {worst[1]} at {worst[0]}, {worst[2]:.2f}x | "
                    f"{_met(worst[2] <= 1.1)} |")
    return rows


def _analysis_goals(rec: dict) -> list[str]:
    """The goal of the analysis against the simulation: in a process of its own, and where
    its imports are paid."""
    rows = []
    for size, m in rec.get("sizes", {}).items():
        if "figures" not in m["scenes"]:
            continue
        r = m["scenes"]["figures"]
        ratio = r["analyze_s"] / r["loop_s"]
        rows.append(f"| the analysis at most a fifth of the simulation | {size}, default scene: "
                    f"`bkflow analyze` (a process of its own) {r['analyze_s']:.2f} s against "
                    f"the loop's {r['loop_s']:.2f} s ({ratio:.2f}) | {_met(ratio <= 0.2)} |")
    for size, r in sorted(rec.get("warm", {}).items(), key=lambda kv: len(kv[0])):
        ratio = r["analyze_s"] / r["loop_s"]
        rows.append(f"| | {size}, default scene, t_end {r['t_end']:g}: the analysis where its "
                    f"imports are paid (a sweep's warm worker) {r['analyze_s']:.2f} s against "
                    f"the loop's {r['loop_s']:.2f} s ({ratio:.2f}) | {_met(ratio <= 0.2)} |")
    return rows


def scene_goals() -> str:
    """The goals of bkflow 0.5.0's scenes against the records: bytes, the loop, and the
    analysis against the simulation."""
    rec = record("scene_bytes") or {}
    rows = ["| goal | measured | |", "|---|---|---|"] + _byte_goals(rec) + _analysis_goals(rec)
    return "\n".join(rows) + "\n"


def scaling_module():
    from benchmarks.report import scaling_model as sm

    return sm


def scaling() -> str:
    """One fused rank against two (benchmarks/report/scaling_model.py's MEASURED, the last line
    of ``python -m benchmarks.measure.throughput --scaling``): time per step, atom-steps/s, the
    speed-up and the two ranks' halo exchange (the slower rank's, its wait included)."""
    sm = scaling_module()
    out = ["| lattice | N | fused, 1 rank: us/step | fused, 2 ranks: us/step | fused, 1 rank: "
           "atom-steps/s | fused, 2 ranks: atom-steps/s | fused 2 / fused 1 | halo us/step | "
           "halo share of the step |", "|---|---|---|---|---|---|---|---|---|"]
    for lx, n, t1, t2, halo in sorted(sm.MEASURED, key=lambda r: r[1]):
        out.append(f"| {lx:.0f}x{n / lx:.0f} | {n:.0f} | {t1 * 1e6:.1f} | {t2 * 1e6:.1f} | "
                   f"{n / t1:.3e} | {n / t2:.3e} | {t1 / t2:.2f} | {halo * 1e6:.2f} | "
                   f"{100 * halo / t2:.0f}% |")
    return "\n".join(out) + "\n"


def scaling_model() -> str:
    """What ``python -m benchmarks.report.scaling_model`` prints: the model fitted to MEASURED and
    its predictions."""
    import contextlib
    import io

    sm = scaling_module()
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        sm.main([])
    lines = buf.getvalue().rstrip("\n").splitlines()
    # the first two lines (c(n), the fitted constants) are paragraphs of their own
    return "\n".join(["- " + lines[0], "- " + lines[1]] + lines[2:]) + "\n"


#: the largest lattice of the size trend, out of this machine's reach: its grid
LARGEST = {"phi": (10.0, 100.0, 1000.0), "size": (240, 60), "seeds": 2}


def largest_grid() -> str:
    """The grid of the largest lattice (N = 14400 at phi = 10, 100, 1000) under the steady
    protocol, and what it costs at most (bkflow.lammps.limits.cost of its runs: every run to
    its cap), in core-hours at the rate the estimate assumes."""
    from bkflow.lammps.limits import ATOM_STEPS_PER_SECOND, Cost, cost, fmt_bytes
    from bkflow.model.protocols import protocol_fields
    from bkflow.sweeps.grid import sweep_specs

    lx, ly = LARGEST["size"]
    specs = sweep_specs(list(LARGEST["phi"]), [LARGEST["size"]], LARGEST["seeds"],
                        **protocol_fields("steady"))
    total = sum((cost(s) for s in specs), Cost(0, 0, 0))
    phis = ",".join(f"{p:g}" for p in LARGEST["phi"])
    return (f"`bkflow sweep --phi {phis} --sizes {lx}x{ly} --seeds {LARGEST['seeds']} --init "
            f"--out runs/n{lx * ly}`: {len(specs)} runs, at most {total.atom_steps:.2g} "
            f"atom-steps, {total.atom_steps / ATOM_STEPS_PER_SECOND / 3600:.1f} core-hours at "
            f"{ATOM_STEPS_PER_SECOND:.0e} atom-steps/s (every run to its cap t_end = "
            f"{specs[0].t_end:g}), {fmt_bytes(total.disk_bytes)} on disk.\n")


#: the blocks this module makes, by name
BLOCKS = {"main-command": main_command,
          "readme-numbers": readme_numbers,
          "steady-sizes": steady_sizes,
          "fixed-cost": fixed_cost,
          "scene-bytes": scene_bytes,
          "scene-goals": scene_goals,
          "scaling": scaling,
          "scaling-model": scaling_model,
          "largest-grid": largest_grid}
