"""The three places where bkflow reaches into signac-flow beyond its public API, in one module.

- a FlowProject's template directory (``_template_dir``): our cluster template lives in the
  package, not in every sweep directory's ``templates/``;
- the jobs of a pending operation (``_JobOperation._jobs``): to start the most expensive run
  first;
- flow's own "Serialize tasks" progress bar (``flow.project.tqdm``), printed unconditionally
  when running in parallel, which would garble ours.

:func:`check` asserts all three still exist; a test calls it, so a flow upgrade that moves
one fails loudly instead of silently losing the feature. pyproject.toml pins flow's minor.
"""

from __future__ import annotations

import contextlib


def set_template_dir(project, path: str) -> None:
    project._template_dir = str(path)


def operation_jobs(op) -> tuple:
    return tuple(getattr(op, "_jobs", ()))


@contextlib.contextmanager
def quiet_flow_bars():
    """Silence flow's own progress bars while ours counts the runs."""
    import flow.project as fp

    original = fp.tqdm
    fp.tqdm = lambda iterable, *args, **kwargs: iterable
    try:
        yield
    finally:
        fp.tqdm = original


def check(project) -> None:
    """Raise AssertionError naming what moved when flow no longer has what we use."""
    import flow.project as fp

    assert hasattr(fp, "tqdm"), "flow.project.tqdm is gone: update bkflow.flowcompat"
    assert hasattr(project, "_template_dir"), \
        "FlowProject._template_dir is gone: update bkflow.flowcompat"
    ops = list(project._get_pending_operations()) if hasattr(
        project, "_get_pending_operations") else []
    for op in ops[:1]:
        assert hasattr(op, "_jobs"), "flow's _JobOperation._jobs is gone: update bkflow.flowcompat"
