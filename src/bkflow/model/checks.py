"""The checks of one parameter's value: each field of RunSpec and AnalysisSettings carries its
own (its dataclass metadata), a function (name, value) -> None that raises a SpecError naming
the field and its range."""

from __future__ import annotations

import dataclasses
import math


class SpecError(ValueError):
    """A parameter outside its meaning; the message names the field and the accepted range."""


# ------------------------------------------------------------------------ checks of one value
# Each field of RunSpec and AnalysisSettings carries its own check (its dataclass metadata):
# a function (name, value) -> None that raises a SpecError naming the field and its range.


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def number(gt: float | None = None, ge: float | None = None, lt: float | None = None,
           le: float | None = None, why: str = "", optional: bool = False, noun: str = ""):
    """A check: a finite number within the bounds given (``why``: what the bound means,
    after it; ``noun``: before it, as in "a number > 0"), or None when ``optional``."""
    def check(name, v):
        if optional and v is None:
            return
        if not _is_number(v):
            what = f"{noun}> {gt:g}" if noun and gt is not None else "a finite number"
            raise SpecError(f"{name} must be {what}, got {v!r}")
        for bound, ok, sign in ((gt, lambda b: v > b, ">"), (ge, lambda b: v >= b, ">="),
                                (lt, lambda b: v < b, "<"), (le, lambda b: v <= b, "<=")):
            if bound is not None and not ok(bound):
                raise SpecError(f"{name} must be {noun}{sign} {bound:g}{why}, got {v!r}")
    return check


def interval(lo: float, hi: float):
    """A check: a number in the open interval (lo, hi)."""
    def check(name, v):
        if not (_is_number(v) and lo < v < hi):
            raise SpecError(f"{name} must lie in ({lo:g}, {hi:g}), got {v!r}")
    return check


def fraction(closed_high: bool = False, why: str = "", optional: bool = False):
    """A check: a number in [0, 1) (or (0, 1] with ``closed_high``), or None when
    ``optional``."""
    def check(name, v):
        if optional and v is None:
            return
        ok = _is_number(v) and (0 < v <= 1 if closed_high else 0 <= v < 1)
        if not ok:
            span = "(0, 1]" if closed_high else "[0, 1)"
            raise SpecError(f"{name} must lie in {span}{why}, got {v!r}")
    return check


def integer(ge: int, phrase: str | None = None, tail: str = "", le: int | None = None):
    """A check: an int (not a bool) >= ge (and <= le, if given); ``phrase`` replaces "an
    integer >= ge" in the message, ``tail`` follows it."""
    def check(name, v):
        if (not isinstance(v, int) or isinstance(v, bool) or v < ge
                or (le is not None and v > le)):
            bounds = f"an integer >= {ge}" if le is None else f"an integer from {ge} to {le}"
            raise SpecError(f"{name} must be {phrase or bounds}, got {v!r}{tail}")
    return check


def choice(options, optional: bool = False):
    """A check: one of ``options`` (or None when ``optional``)."""
    def check(name, v):
        if optional and v is None:
            return
        if v not in options:
            none = "none or " if optional else ""
            raise SpecError(f"{name} must be {none}one of {', '.join(options)}, got {v!r}")
    return check


def boolean(name, v):
    """A check: True or False."""
    if not isinstance(v, bool):
        raise SpecError(f"{name} must be true or false, got {v!r}")


def checked(default=dataclasses.MISSING, check=None, **kw):
    """A dataclass field with its check (see ``check_fields``)."""
    return dataclasses.field(default=default, metadata={"check": check}, **kw)


def check_fields(obj, prefix: str = "") -> None:
    """Every field's own check; ``prefix`` names what the field is (e.g. "analysis setting
    ")."""
    for f in dataclasses.fields(obj):
        check = f.metadata.get("check")
        if check is not None:
            check(prefix + f.name, getattr(obj, f.name))
