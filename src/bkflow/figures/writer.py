"""``bkflow plot``'s writer: ``plot`` writes a sweep's figures (the catalogue,
``bkflow.figures.catalogue.FIGURES``) into its figures directory, one set per combination of
the other parameters a sweep varies, atomically, never over a user's file, and records them
with the tables they were drawn from (``figures.json``), so that a sweep or collect that
changes the tables retires them.
"""

from __future__ import annotations

import json
from pathlib import Path

from bkflow.figures.catalogue import FIGURES, figure
from bkflow.figures.data import SweepData, where_of
from bkflow.figures.style import STYLE, PlotError, new_figures, style
from bkflow.store.errors import RunBusyError
from bkflow.store.files import MARK, atomic_file, foreign_file, inside, within
from bkflow.store.formats import read_text
from bkflow.store.rundir import RunDir
from bkflow.store.tables import (
    FIGURES_DIR,
    FIGURES_RECORD,
    record_figures,
    tables_digest,
    varied_parameters,
)

#: the formats ``bkflow plot`` writes by default
FORMATS = ("png", "pdf")


def plot(root, out=None, formats=FORMATS, where: dict | None = None) -> tuple[list[Path], dict]:
    """Write every figure that the sweep in ``root`` has data for into ``out`` (default
    ``root/figures``), of the runs matching ``where`` ({column: value}; all by default).
    A sweep that varies other parameters too (``bkflow sweep --vary``) gets one set of
    figures per combination, in subdirectories ``NAME=VALUE[,NAME=VALUE]``. The figures are
    recorded with the tables they were drawn from (``figures.json``): a sweep or collect that
    changes the tables removes them (``bkflow.store.tables.retire_figures``).
    Returns (paths written, {figure: why it was skipped})."""
    # the sweep's own figures directory is written and emptied by bkflow: never through a link
    out = Path(out) if out is not None else inside(root, FIGURES_DIR, "the figures directory")
    _check_sweep(root, where)
    with RunDir(root).lock():
        digest = tables_digest(root)
        data = SweepData(root, where)
        _check_formats(formats)
        recorded, same = _last_record(out, digest, where)
        kept = [out / f for f in sorted(recorded)] if same else []
        # figures of other tables, or of another --where: not what this plot shows; those it
        # does not draw again are removed, so that the directory holds one record's figures
        stale = [] if same else [out / f for f in sorted(recorded)]
        targets = _check_targets(out, formats, recorded)
        out.mkdir(parents=True, exist_ok=True)
        # while figures are being written the record says so: an interrupted plot leaves
        # complete = false, and a later change of the tables still retires what it wrote
        record_figures(root, out, sorted({*kept, *targets, *stale}), where, complete=False,
                       digest=digest)
        written, skipped = _plot(data, out, formats, where, recorded)
        for p in stale:
            if p not in written and p.is_file() and not p.is_symlink():
                p.unlink()
        record_figures(root, out, sorted({*kept, *written}), where, complete=True,
                       digest=digest)
    return written, skipped


def _check_sweep(root, where) -> None:
    """Refuse a directory with nothing to plot before anything, a lock file too, is written;
    where a collect or sweep is writing its tables, say so (its tables are half made, not
    wrong). A plot then holds the sweep's lock: no collect or sweep (the tables' writers)
    rewrites the tables while it draws from them, and the record names the tables as they
    were read."""
    try:
        SweepData(root, where)
    except PlotError:
        if RunDir(root).busy():
            raise RunBusyError(f"another bkflow process (a collect or sweep) is writing "
                               f"{root}'s tables now; plot once it is done") from None
        raise


def _last_record(out: Path, digest: str, where) -> tuple[set, bool]:
    """The files that the record of the figures in ``out`` (figures.json) names, and whether
    it records the same tables (``digest``) and the same ``where``; none, where there is no
    readable record."""
    try:
        old = json.loads(read_text(out / FIGURES_RECORD))
        if not isinstance(old, dict) or not isinstance(old["files"], list):
            raise TypeError("not a record of figures")
        # only plain names inside the figures directory are the record's (an absolute
        # path, '..' or a name through a link is nobody's to keep, replace or remove)
        recorded = {f for f in old["files"] if isinstance(f, str) and within(out, f)}
        same = (old.get("tables_sha256") == digest and old.get("where") == (where or None))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        recorded, same = set(), False
    return recorded, same


def _check_formats(formats) -> None:
    """Refuse a format that matplotlib does not write, naming those it does."""
    plt = new_figures()
    supported = plt.figure().canvas.get_supported_filetypes()
    bad = [f for f in formats if f not in supported]
    if bad:
        raise PlotError(f"format {', '.join(bad)} is not one matplotlib writes; choose from "
                        f"{', '.join(sorted(supported))}")


def _check_targets(out: Path, formats, recorded) -> list[Path]:
    """The files a plot writes into ``out``; a user's file among them (not written by bkflow,
    not in ``recorded``, the names figures.json lists) is never replaced: PlotError."""
    targets = [out / f"{name}.{fmt}" for name in FIGURES for fmt in formats]
    for p in targets:
        why = foreign_file(p, recorded)
        if why is not None:
            raise PlotError(why)
    return targets


def _plot(data: SweepData, out: Path, formats, where, recorded) -> tuple[list[Path], dict]:
    """The figures of ``data`` into ``out`` (formats checked, the top directory's targets
    too); a sweep that varies other parameters: one subdirectory per combination, whose
    targets are checked here against ``recorded`` (relative to the top directory)."""
    varied = varied_parameters(data.results)
    if varied:
        written, skipped = [], {}
        combos = data.results[varied].astype(str).drop_duplicates().to_dict("records")
        for combo in combos:
            # one directory per combination (a '/' in a value, reset/step, would nest one)
            name = ",".join(f"{k}={v}" for k, v in combo.items()).replace("/", "-")
            sub = {**(where or {}), **where_of(combo)}
            inner = {f[len(name) + 1:] for f in recorded if f.startswith(name + "/")}
            _check_targets(out / name, formats, inner)
            w, s = _plot(SweepData(data.root, sub), out / name, formats, sub, inner)
            written += w
            skipped.update({f"{name}/{k}": v for k, v in s.items()})
        return written, skipped
    out.mkdir(parents=True, exist_ok=True)
    written, skipped = [], {}
    for name in FIGURES:
        try:
            fig = figure(data, name)
        except PlotError as exc:
            skipped[name] = str(exc)
            continue
        except ValueError as exc:  # e.g. --where leaves nothing positive for a log axis
            skipped[name] = f"nothing to draw for these runs ({' '.join(str(exc).split())})"
            continue
        with style():
            written += save_figure(fig, out, name, formats)
    return written, skipped


def save_figure(fig, out: Path, name: str, formats) -> list[Path]:
    """Write ``fig`` as ``out/name.FMT``, atomically and marked (targets checked before)."""
    paths = []
    for fmt in formats:
        p = out / f"{name}.{fmt}"
        meta = {"Creator": MARK} if fmt in ("png", "pdf", "svg", "ps", "eps") else None
        try:
            with atomic_file(p, binary=True) as f:  # SIGTERM or a full disk: the old figure
                fig.savefig(f, format=fmt, metadata=meta, dpi=STYLE["savefig.dpi"],
                            bbox_inches="tight")
        except (RuntimeError, ValueError) as exc:  # pgf without LaTeX, and the like
            why = " ".join(str(exc).split())[:160]
            raise PlotError(f"matplotlib cannot write {fmt} here ({why}); choose another "
                            "--format") from None
        paths.append(p)
    return paths
