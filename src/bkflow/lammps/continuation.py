"""A finished run and a new request for the same layer: whether the run there already is the
run asked for (``answers``), whether the request goes on with it from its restart file
(``continuation``), and why neither where the request is of another length
(``other_request``). The engine (``bkflow.lammps.engine.run``) and the sweeps
(``bkflow.sweeps``) decide by these alone.
"""

from __future__ import annotations

from bkflow.model.params import RunSpec
from bkflow.store.rundir import RunDir

#: the fields of a RunSpec that say how long a run goes on, not what it runs: a request that
#: differs from a finished run in these alone may continue it, or be answered by it
LENGTH_FIELDS = ("t_end", "target_error")


def _finished(rd: RunDir) -> tuple[RunSpec, dict] | None:
    """The request and record of the intact finished run in ``rd``, or None."""
    if not rd.is_complete() or rd.problem() is not None:
        return None
    meta = rd.meta()
    try:
        return RunSpec.from_dict(meta["requested"]), meta
    except Exception:  # a record of another version: neither continued nor answering
        return None


def _same_layer(before: RunSpec, spec: RunSpec) -> bool:
    """Whether two requests differ in their length (LENGTH_FIELDS) alone."""
    return before.replace(**{f: getattr(spec, f) for f in LENGTH_FIELDS}) == spec


def _stricter(old: float | None, new: float | None) -> bool:
    """Whether an error target ``new`` asks more than ``old`` (None: no target)."""
    return new is not None and (old is None or new < old)


def answers(rd: RunDir, spec: RunSpec, identical: bool = True) -> bool:
    """Whether the finished run in ``rd`` is the very run ``spec`` asks for: the same request
    (``identical``), or an adaptive run that stopped by its rule before ``spec``'s cap with
    the same rule, which a run asked for with the longer cap makes in the same steps (its
    checks come at the same steps, ``check_chunk``) and stops at the same one."""
    found = _finished(rd)
    if found is None:
        return False
    before, meta = found
    if before == spec:
        return identical
    if not _same_layer(before, spec) or before.target_error != spec.target_error:
        return False
    stopped = (meta.get("adaptive") or {}).get("reached") and before.adaptive
    return bool(stopped) and spec.n_steps >= int(meta["derived"]["n_steps"])


def other_request(rd: RunDir, spec: RunSpec) -> str | None:
    """Why the finished run in ``rd``, of the same layer as ``spec``, neither answers nor is
    continued by ``spec`` (None: another layer, or no finished run)."""
    found = _finished(rd)
    if found is None or not _same_layer(found[0], spec) or found[0] == spec:
        return None
    before, meta = found
    t_run = int(meta["derived"]["n_steps"]) * before.dt
    if before.target_error is not None and not _stricter(
            before.target_error, spec.target_error) and before.target_error != spec.target_error:
        return (f"it ran to t = {t_run:g} for mu_bar error <= {before.target_error:g}, a "
                "stricter target than this request's: a run continues only to a longer cap "
                "or a smaller --target-error")
    return (f"it ran to t = {t_run:g} (asked for t_end {before.t_end:g}); a run continues "
            "only to a longer --t-end or a smaller --target-error")


def _goes_on(before: RunSpec, meta: dict, spec: RunSpec) -> bool:
    """Whether ``spec`` asks more of the finished run of ``before`` (its record ``meta``) than
    it ran, under a rule that would not have stopped it sooner."""
    if not _same_layer(before, spec) or spec.n_steps <= int(meta["derived"]["n_steps"]):
        return False
    stricter = _stricter(before.target_error, spec.target_error)
    if before.adaptive and (meta.get("adaptive") or {}).get("reached"):
        return stricter   # it stopped by its own rule: a longer cap alone changes nothing
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
    found = _finished(rd)
    if found is None:
        return None
    before, meta = found
    if not _goes_on(before, meta, spec):
        return None
    if not all((d.meta() or {}).get("restart") and d.file(d.meta()["restart"]).is_file()
               for d in legs):
        return None
    return meta
