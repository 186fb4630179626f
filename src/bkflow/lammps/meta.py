"""The completion record of a run, meta.json: what ran (the versions, the plugin, the
provenance, the parameters asked for and those that ran), how long it took, the engine's
counters, and, for a run continued from a shorter one, the parts it was run in.
"""

from __future__ import annotations

import os
import platform
import time

from bkflow import __version__
from bkflow.lammps.adaptive import AdaptiveStop
from bkflow.lammps.plugin import build_info, lammps_version
from bkflow.model.params import RunSpec
from bkflow.store.provenance import record as provenance

#: runs this process has committed: a sweep's worker runs many, and pays Python's imports, the
#: plugin check and the loading of LAMMPS once (meta.json "process"); a forked worker starts
#: its own count (the pid tells)
_RUNS_IN_PROCESS = {"pid": None, "runs": 0}


def process_record() -> dict:
    """meta.json's "process": this process' pid and the runs it committed before this one."""
    if _RUNS_IN_PROCESS["pid"] != os.getpid():
        _RUNS_IN_PROCESS.update(pid=os.getpid(), runs=0)
    return {"pid": os.getpid(), "runs_before": _RUNS_IN_PROCESS["runs"]}


def count_committed() -> None:
    """One more run committed by this process."""
    _RUNS_IN_PROCESS["runs"] += 1


def run_meta(requested: RunSpec, step: int, wall: float, started: float, counters: dict,
             adaptive: AdaptiveStop | None, command: str | None, legs: int = 1,
             before: dict | None = None, start: int = 0) -> dict:
    """meta.json of a run that ran ``step`` steps (an adaptive run that met its target is a
    run of that length); ``legs``: the LAMMPS runs that shared the wall time (2 with a
    companion); ``before``: the record of the run this one continued from step ``start``
    (its wall time and counters add up, ``continued`` lists the parts)."""
    meta = _fresh(requested, step, wall, started, counters, adaptive, command, legs,
                  step - start)
    if before is None:
        return meta
    meta["wall_time_s"] = before.get("wall_time_s", 0.0) + wall
    for key in ("slip_snapshots", "fronts"):   # the output fixes count from their restart
        if meta.get(key) and before.get(key):
            meta[key] = {k: v + before[key].get(k, 0) for k, v in meta[key].items()}
    # so do the overshoots (the breaks come back with the layer's restart state)
    meta["contact_overshoots"] = meta.get("contact_overshoots", 0) + before.get(
        "contact_overshoots", 0)
    meta["continued"] = before.get("continued", [{"to_step": start,
                                                   "command": before.get("command")}]) + [
        {"to_step": step, "command": command, "wall_time_s": wall}]
    meta["started"] = before.get("started", meta["started"])
    return meta


def _fresh(requested: RunSpec, step: int, wall: float, started: float, counters: dict,
           adaptive: AdaptiveStop | None, command: str | None, legs: int,
           steps_run: int) -> dict:
    """meta.json of a run of ``step`` steps, ``steps_run`` of them in ``wall`` seconds."""
    stopped_early = step < requested.n_steps
    spec = requested.replace(t_end=step * requested.dt) if stopped_early else requested
    return {
        "bkflow": __version__,
        **lammps_version(),
        "plugin": build_info(),
        "provenance": provenance(),
        "params": spec.to_dict(),
        "requested": requested.to_dict(),
        "adaptive": None if adaptive is None else adaptive.record(requested, spec.t_end,
                                                                  stopped_early),
        "derived": {"N": spec.N, "k_b": spec.k_b, "dt": spec.dt, "dt_rule": spec.dt_rule,
                    "n_steps": step,
                    "stress_nevery": spec.stress_nevery,
                    "stress_dt": spec.stress_nevery * spec.dt,
                    "snapshot_nevery": spec.snapshot_nevery if spec.writes_snapshots else None,
                    "slip_threshold_stress": spec.slip_threshold_stress,
                    "transient_step": spec.transient_step},
        "scene": spec.scene,
        "seed": spec.seed,
        "wall_time_s": wall,
        "atom_steps_per_s": legs * spec.N * steps_run / wall if wall > 0 else None,
        **counters,
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(started)),
        "host": platform.node(),
        "command": command,
    }
