"""A finished run and a new request for the same layer: whether the run there already is the
run asked for (``answers``), whether the request goes on with it from its restart file
(``continuation``), and why neither where the request is of another length
(``other_request``). The engine (``bkflow.lammps.engine.run``) and the sweeps
(``bkflow.sweeps``) decide by these alone.
"""

from __future__ import annotations

from bkflow.model.params import RunSpec
from bkflow.store.layout import EXTREMA
from bkflow.store.rundir import RunDir

#: the fields of a RunSpec that say how long a run goes on, not what it runs: a request that
#: differs from a finished run in these alone may continue it, or be answered by it
LENGTH_FIELDS = ("t_end", "target_error")


def finished(rd: RunDir) -> tuple[RunSpec, dict] | None:
    """The request and record of the intact finished run in ``rd`` that this bkflow can go on
    with or answer by, or None: a record of another version is neither (its request no
    longer reads, its step is not the one its request gives now, or it stopped under another
    stop rule: ``bkflow.lammps.adaptive.RULE``)."""
    from bkflow.lammps.adaptive import RULE

    if not rd.is_complete() or rd.problem() is not None:
        return None
    meta = rd.meta()
    try:
        before = RunSpec.from_dict(meta["requested"])
        same_step = abs(float(meta["derived"]["dt"]) / before.dt - 1) < 1e-12
    except Exception:
        return None
    if not same_step or (before.adaptive and (meta.get("adaptive") or {}).get("rule") != RULE):
        return None
    return before, meta


def _same_layer(before: RunSpec, spec: RunSpec) -> bool:
    """Whether two requests differ in their length (LENGTH_FIELDS) alone, and are both
    adaptive or both fixed (a fixed run checked no rule, so an adaptive request is another
    run)."""
    return (before.replace(**{f: getattr(spec, f) for f in LENGTH_FIELDS}) == spec
            and before.adaptive == spec.adaptive)


def _stricter(old: float | None, new: float | None) -> bool:
    """Whether an error target ``new`` asks more than ``old`` (None: no target)."""
    return new is not None and (old is None or new < old)


def _stopped_by_rule(before: RunSpec, meta: dict) -> bool:
    """Whether an adaptive run stopped by its rule before its cap (a run that met its rule at
    the cap itself, which is no check of the schedule, is a capped run: a longer cap checks
    on)."""
    return before.adaptive and int(meta["derived"]["n_steps"]) < before.n_steps


def answers(rd: RunDir, spec: RunSpec, identical: bool = True) -> bool:
    """Whether the finished run in ``rd`` is the very run ``spec`` asks for: the same request
    (``identical``), or an adaptive run that stopped by its rule before its cap, asked for
    with a cap at least as long and the same rule, or a stricter one that its records meet at
    the step it stopped: a run asked for that way makes the same steps (its checks come at the
    same steps, ``check_chunk``) and stops at the same one. (Its record keeps the request it
    was run for.)"""
    found = finished(rd)
    if found is None:
        return False
    before, meta = found
    if before == spec:
        return identical
    done = int(meta["derived"]["n_steps"])
    if not (_same_layer(before, spec) and _stopped_by_rule(before, meta)
            and spec.n_steps >= done):
        return False
    if before.target_error == spec.target_error:
        return True
    # a stricter target that the run met where it stopped: the run asked for with it stops
    # at the same check
    from bkflow.lammps.adaptive import rule_met_at

    return _stricter(before.target_error, spec.target_error) and rule_met_at(spec, rd, done)


def other_request(rd: RunDir, spec: RunSpec) -> str | None:
    """Why the finished run in ``rd`` neither answers nor is continued by ``spec`` (None: no
    finished run there, or another layer's)."""
    from bkflow.lammps.adaptive import RULE

    if rd.is_complete() and rd.problem() is None and (rd.meta().get("adaptive") or {}).get(
            "rule", RULE) != RULE:
        return ("it stopped under the stop rule of an earlier bkflow, which this one does not "
                "go on with")
    found = finished(rd)
    if found is None or found[0] == spec:
        return None
    before, meta = found
    if before.adaptive != spec.adaptive and before.replace(
            **{f: getattr(spec, f) for f in LENGTH_FIELDS}) == spec.replace(
            until_steady=before.until_steady):
        return ("it ran under a stop rule, and a request of a fixed length is another run"
                if before.adaptive else "it is a run of a fixed length, and a request with a "
                "stop rule is another run")
    return _length_reason(before, meta, spec) if _same_layer(before, spec) else None


def _length_reason(before: RunSpec, meta: dict, spec: RunSpec) -> str:
    """Why a request of the same layer as a finished run, of another length, neither
    answers it nor goes on with it."""
    t_run = int(meta["derived"]["n_steps"]) * before.dt
    if before.target_error is not None and not _stricter(
            before.target_error, spec.target_error) and before.target_error != spec.target_error:
        return (f"it ran to t = {t_run:g} for mu_bar error <= {before.target_error:g}, a "
                "stricter target than this request's: a run continues only to a longer cap "
                "or a smaller --target-error")
    if not _stopped_by_rule(before, meta) and spec.t_end <= before.t_end:
        return (f"it ran to its cap, t = {t_run:g}: a run continues only to a longer --t-end "
                "(with a smaller --target-error or without)")
    return (f"it stopped by its rule at t = {t_run:g}, before a cap of {spec.t_end:g}: a run "
            "continues only to a longer cap or a smaller --target-error")


def _goes_on(before: RunSpec, meta: dict, spec: RunSpec) -> bool:
    """Whether ``spec`` asks more of the finished run of ``before`` (its record ``meta``) than
    it ran, under a rule that would not have stopped it sooner."""
    if not _same_layer(before, spec) or spec.n_steps <= int(meta["derived"]["n_steps"]):
        return False
    stricter = _stricter(before.target_error, spec.target_error)
    if _stopped_by_rule(before, meta):
        # it stopped by its own rule: a longer cap alone changes nothing, and a stricter
        # target that its records meet where it stopped is answered by it (``answers``)
        return stricter
    # a looser rule might have stopped it sooner
    return stricter or before.target_error == spec.target_error


def continuation(rd: RunDir, spec: RunSpec) -> dict | None:
    """The completion record of the finished run in ``rd`` that ``spec`` continues, or None:
    the same run (every parameter but the length, LENGTH_FIELDS, and the companion's too)
    that ran fewer steps than ``spec`` may run and would not have stopped before them under
    ``spec``'s rule: one that ran to its cap, asked for a longer cap under the same or a
    stricter error target, or one that stopped by its own rule, asked for a stricter target.
    A longer run then continues from where it stopped and never simulates again what it has:
    its series are appended to, and its trajectory is the very one the request makes from the
    start (bit for bit on the fused path, whose restart is exact), its stop rule checked at
    the very steps (``check_chunk``, ``next_check``)."""
    legs = [rd] + ([rd.companion()] if spec.companion is not None else [])
    for d in legs:  # a continuation cut short: the finished run as it was
        d.undo_continuation()
    found = finished(rd)
    if found is None:
        return None
    before, meta = found
    if not _goes_on(before, meta, spec) or answers(rd, spec):
        return None
    if not all((d.meta() or {}).get("restart") and d.file(d.meta()["restart"]).is_file()
               for d in legs):
        return None
    if spec.companion is not None and not rd.companion().file(EXTREMA).is_file():
        return None   # a companion that kept no turning points (bkflow before 0.6)
    return meta
