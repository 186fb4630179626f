"""What every block module shares: numbers as a block's cells show them, and the records a
block reads (benchmarks/records/, workflows/paper/claims.json).
"""

from __future__ import annotations

import math

from benchmarks.harness import RECORDS, ROOT, read_json

#: the paper's claims (workflows/paper/claims.json, written by workflows/paper/reproduce.py)
CLAIMS = ROOT / "workflows" / "paper" / "claims.json"


def pct(v, digits=2) -> str:
    return "n/a" if v is None or not math.isfinite(v) else f"{100 * v:+.{digits}f}%"


def se(v, digits=2) -> str:
    """A standard error as a percentage without its sign (n/a where there is none)."""
    return "n/a" if v is None or not math.isfinite(v) else f"{100 * v:.{digits}f}%"


def num(v, fmt=".4f") -> str:
    return "n/a" if v is None or not math.isfinite(v) else format(v, fmt)


def record(name: str) -> dict | None:
    """benchmarks/records/NAME.json, or None where it has not been measured yet."""
    return read_json(RECORDS / f"{name}.json")


def readme_record() -> dict:
    """The README's record (benchmarks/records/readme_numbers.json)."""
    return read_json(RECORDS / "readme_numbers.json")


def claims_module():
    """workflows/paper/claims.py, the paper's claims and their tests (a script of the paper's
    workflow, loaded from its file)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("claims", CLAIMS.with_suffix(".py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
