"""The one parser of bkflow's NAME=VALUE text: the command line's ``--set``, ``--vary``,
``--analysis`` and ``--where``, and the lattice sizes of ``--size``, ``--sizes`` and
``--aspect``.

Text comes in, typed values go out: a RunSpec field's value converted to the field's type, an
AnalysisSettings changed by ``dataclasses.replace`` (whose checks run there), a ``--where``
value as a number, true/false, none or a word. The model (``bkflow.model.params``) takes typed
values only and keeps the checks of what they may be; every error here is a ``SpecError``
naming the option and what it was given.
"""

from __future__ import annotations

import dataclasses
import math
import re
from fractions import Fraction

from bkflow.model.checks import SpecError
from bkflow.model.params import PAPER_SIZES, RunSpec
from bkflow.model.settings import AnalysisSettings
from bkflow.sweeps.grid import ASPECT

#: RunSpec fields with an axis or option of their own in the CLI (--phi, --size, --seed);
#: every other field can be set with --set NAME=VALUE and swept with --vary NAME=V1,V2,...
OWN_OPTIONS = {"phi": "--phi", "Lx": "--size", "Ly": "--size", "seed": "--seed/--seeds"}
#: words of ``--analysis`` that mean "the run's own" for the settings that default to it
RUN_WORDS = ("none", "run")


# ------------------------------------------------------------------------ NAME=VALUE
def split_assignment(item, option: str, values: bool = False) -> tuple[str, list[str] | str]:
    """(NAME, VALUE) of ``NAME=VALUE`` (``-`` in NAME reads as ``_``), or with ``values``
    (NAME, [V1, V2, ...]) of ``NAME=V1,V2,...``: the split of every NAME=VALUE option
    (--set, --vary, --analysis, --where)."""
    name, sep, text = str(item).partition("=")
    name = name.strip().replace("-", "_")
    if not values:
        if not sep or not name:
            raise SpecError(f"{option} {item!r}: give NAME=VALUE")
        return name, text
    if not sep or not name or not text.strip():
        raise SpecError(f"{option} {item!r}: give NAME=V1,V2,...")
    parts = text.split(",")
    if any(not v.strip() for v in parts):
        raise SpecError(f"{option} {item!r}: an empty value in the list")
    return name, parts


def _guess(t: str):
    """A value of no declared type: a number, true/false, or the word itself."""
    try:
        return float(t)
    except ValueError:
        return {"true": True, "false": False}.get(t.lower(), t)


def _convert(kind: str, t: str):
    """``t`` (stripped, not empty) as a value of the type annotation ``kind``; ValueError if it
    is none."""
    if kind == "any":
        return _guess(t)
    if kind.startswith("bool"):
        if t.lower() not in ("true", "false", "yes", "no", "1", "0"):
            raise ValueError
        return t.lower() in ("true", "yes", "1")
    if kind.startswith("int"):
        return int(t)
    if kind.startswith("float"):
        return float(t)
    if kind.startswith("tuple"):
        return tuple(float(v) for v in t.strip("[]()").split(",") if v.strip())
    return t


def parse_typed(kind: str, text: str, what: str, none_words=("none",)):
    """``text`` as a value of the type annotation ``kind`` (bool, int, float, str, tuple of
    floats, X | None); ``kind`` "any" guesses (a number, true/false, none or a word).
    ``what`` names the value in the SpecError (e.g. "--set gamma=x")."""
    t = str(text).strip()
    if t == "":
        raise SpecError(f"{what}: give a value after '='")
    if ("None" in kind or kind == "any") and t.lower() in none_words:
        return None
    try:
        return _convert(kind, t)
    except ValueError:
        shown = ("true or false" if kind.startswith("bool") else "numbers"
                 if kind.startswith("tuple") else f"a {kind.split()[0]}")
        raise SpecError(f"{what}: must be {shown}") from None


# ------------------------------------------------------------------------ lattice sizes
def parse_size(text: str) -> tuple[int, int]:
    """``"20x5"`` -> ``(20, 5)``; a clear ``SpecError`` for anything else."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", str(text))
    if not m:
        raise SpecError(f"size {text!r} is not of the form LXxLY (e.g. 20x5)")
    return int(m.group(1)), int(m.group(2))


def parse_aspect(text) -> float | None:
    """``--aspect``: Lx / Ly that every size must have: a number (``1``, ``0.25``), a ratio
    (``7/3``, exact where a decimal is not), or ``any`` (None)."""
    if text is None:
        return ASPECT
    if str(text).strip().lower() == "any":
        return None
    try:
        num, _, den = str(text).partition("/")
        v = float(num) / float(den) if den else float(num)
    except (ValueError, ZeroDivisionError):
        raise SpecError(f"--aspect {text!r}: give Lx/Ly as a number (e.g. 1), a ratio "
                        "(e.g. 7/3) or 'any'") from None
    if not (math.isfinite(v) and v > 0):
        raise SpecError(f"--aspect must be > 0, got {text}")
    return v


def _sweep_size(item: str) -> tuple[int, int]:
    """One item of ``--sizes``: LXxLY, or a bare N naming one of the paper's lattices."""
    if not item.isdigit():
        return parse_size(item)
    n = int(item)
    if n not in PAPER_SIZES:
        raise SpecError(f"--sizes {item}: a bare number names one of the paper's "
                        f"lattices N = {', '.join(map(str, PAPER_SIZES))}; else LXxLY")
    return PAPER_SIZES[n]


def parse_sizes(text: str, aspect: float | None = ASPECT) -> list[tuple[int, int]]:
    """``"20x5,40x10"`` -> [(20, 5), (40, 10)]; ``100,400`` picks the paper's lattices.
    Every size must have Lx = aspect * Ly unless ``aspect`` is None."""
    sizes = []
    for item in str(text).split(","):
        item = item.strip()
        if not item:
            continue
        lx, ly = _sweep_size(item)
        if aspect is not None and not math.isclose(lx, aspect * ly):
            ratio = Fraction(lx, ly)   # exact: a rounded decimal would not match it again
            paper = " (the paper's lattices have Ly = Lx/4)" if aspect == ASPECT else ""
            raise SpecError(f"--sizes {item}: Lx/Ly = {ratio}, not {aspect:g}{paper}; pass "
                            f"--aspect {ratio} or --aspect any to sweep other shapes")
        sizes.append((lx, ly))
    if not sizes:
        raise SpecError("--sizes: give at least one LXxLY")
    return list(dict.fromkeys(sizes))


# ------------------------------------------------------------------------ a run's parameters
def parse_value(name: str, text: str, option: str = "--set"):
    """The value of RunSpec field ``name`` written as ``text`` (a number, a word, true/false,
    none), converted to the field's type; a SpecError naming ``option`` otherwise."""
    fields = {f.name: f for f in dataclasses.fields(RunSpec)}
    if name not in fields:
        settable = sorted(f for f in fields if f not in OWN_OPTIONS)
        raise SpecError(f"{option} {name}: not a parameter; parameters: "
                        f"{', '.join(settable)}")
    if name in OWN_OPTIONS:
        raise SpecError(f"{option} {name}: use {OWN_OPTIONS[name]} for it")
    kind = str(fields[name].type)
    try:
        return parse_typed(kind, text, f"{option} {name}={str(text).strip()}")
    except SpecError as exc:  # "must be a float" of the field, by name
        raise SpecError(str(exc).replace(": must be", f": {name} must be")) from None


def run_assignments(items, option: str = "--set") -> dict:
    """{name: value} of ``NAME=VALUE`` strings of RunSpec fields; a name given twice is
    refused."""
    out = {}
    for item in items:
        name, text = split_assignment(item, option)
        value = parse_value(name, text, option)
        if name in out:
            raise SpecError(f"{option} {name} given twice")
        out[name] = value
    return out


def run_variations(items, option: str = "--vary") -> dict[str, list]:
    """{name: [values]} of ``NAME=V1,V2,...`` strings of RunSpec fields (a sweep's extra
    axes)."""
    out = {}
    for item in items:
        name, texts = split_assignment(item, option, values=True)
        if name in OWN_OPTIONS:
            raise SpecError(f"{option} {name}: use {OWN_OPTIONS[name]} for it")
        if name in out:
            raise SpecError(f"{option} {name} given twice")
        values = [parse_value(name, v, option) for v in texts]
        if len(set(map(repr, values))) != len(values):
            raise SpecError(f"{option} {name}: a value is given twice")
        out[name] = values
    return out


# ------------------------------------------------------------------------ analysis, figures
def analysis_assignments(items, settings: AnalysisSettings = AnalysisSettings()
                         ) -> AnalysisSettings:
    """``settings`` changed by ``NAME=VALUE`` strings (``--analysis``)."""
    names = {f.name: f for f in dataclasses.fields(settings)}
    changes = {}
    for item in items:
        name, text = split_assignment(item, "--analysis")
        if name not in names:
            raise SpecError(f"--analysis {item!r}: give NAME=VALUE with NAME one of "
                            f"{', '.join(sorted(names))}")
        kind = str(names[name].type)
        try:
            changes[name] = parse_typed(kind, text, f"--analysis {item!r}",
                                        none_words=RUN_WORDS)
        except SpecError as exc:
            if "must be" not in str(exc):
                raise
            raise SpecError(f"--analysis {item!r}: {text.strip()!r} is not a number") \
                from None
    return dataclasses.replace(settings, **changes)


def parse_where(items) -> dict:
    """``["t_end=16000", "start=random"]`` -> {column: value} (numbers where they parse;
    none for a parameter left unset, NaN in the tables): ``bkflow plot --where``. A column
    given more than once keeps the runs with any of its values, as a list:
    ``["phi=10", "phi=100"]`` -> {"phi": [10.0, 100.0]}."""
    out: dict = {}
    for item in items or ():
        try:
            key, text = split_assignment(item, "--where")
            value = None if not text.strip() else parse_typed(
                "any", text, f"--where {item!r}", none_words=("none", "nan"))
        except SpecError as exc:
            raise SpecError(f"{exc}; e.g. --where t_end=16000") from None
        if key in out:
            before = out[key] if isinstance(out[key], list) else [out[key]]
            out[key] = before + [value] if value not in before else before
        else:
            out[key] = value
    return out
