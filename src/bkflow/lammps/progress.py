"""The progress lines of a run and of a sweep: where they are drawn (a terminal, a notebook)
and at what size."""

from __future__ import annotations

import shutil
import sys


def terminal_size(max_columns: int | None = None) -> dict:
    """tqdm's ``ncols`` and ``nrows`` for this terminal (at most ``max_columns`` wide). A
    terminal that reports no size (a bare pseudo-terminal: ``script``, some editors' shells)
    gets shutil's 80x24: tqdm would draw nothing in its 0 rows, and a long run would show no
    sign of life until it ends."""
    size = shutil.get_terminal_size()
    cols = size.columns if max_columns is None else min(max_columns, size.columns)
    return {"ncols": cols, "nrows": size.lines}


def in_notebook() -> bool:
    """Whether this process is a Jupyter kernel (where stderr is no terminal, yet a progress
    bar is wanted)."""
    shell = sys.modules.get("IPython")
    try:
        return shell is not None and type(shell.get_ipython()).__name__ == "ZMQInteractiveShell"
    except Exception:  # an IPython without a running shell
        return False


class RunProgress:
    """A progress bar of the run (steps, sigma_x, ETA) through ``tqdm.auto``: a line on a
    terminal (stderr), a widget in a notebook; silent anywhere else (a pipe, a sweep's
    worker) unless asked for."""

    def __init__(self, label: str, total: int, enabled: bool | None = None):
        if enabled is None:
            enabled = sys.stderr.isatty() or in_notebook()
        self.bar = None
        if enabled:
            from tqdm.auto import tqdm

            # the line fits in 80 columns with a label of 30 (the stress is what one watches)
            self.bar = tqdm(total=total, desc=label, unit="step", unit_scale=True,
                            file=sys.stderr, smoothing=0.1, mininterval=0.5,
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                                       "[{elapsed}<{remaining}{postfix}]",
                            **terminal_size())

    def update(self, step: int, sigma_x: float) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(f"sigma_x {sigma_x:+.4f}", refresh=False)
            self.bar.update(step - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
