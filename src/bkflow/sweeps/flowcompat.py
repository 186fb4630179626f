"""The two places where bkflow reaches into signac-flow beyond its public API, in one module.

- a FlowProject's template directory (``_template_dir``): our cluster template lives in the
  package, not in every sweep directory's ``templates/``;
- flow's own "Serialize tasks" progress bar (``flow.project.tqdm``), printed unconditionally
  when running in parallel, which would garble ours.

``check`` asserts both still exist; a test calls it, so a flow upgrade that moves
one fails loudly instead of silently losing the feature. pyproject.toml pins flow's minor.
"""

from __future__ import annotations

import contextlib


def set_template_dir(project, path: str) -> None:
    project._template_dir = str(path)


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

    assert hasattr(fp, "tqdm"), "flow.project.tqdm is gone: update bkflow.sweeps.flowcompat"
    assert hasattr(project, "_template_dir"), \
        "FlowProject._template_dir is gone: update bkflow.sweeps.flowcompat"
