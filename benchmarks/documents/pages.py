"""The blocks of pages other than RESULTS.md that come from the package and the paper's claims:
docs/analysis.md's summary keys, docs/develop.md's layout table and REPRODUCTION.md's claims.
"""

from __future__ import annotations

import re
from pathlib import Path

from benchmarks.documents.cells import CLAIMS, claims_module
from benchmarks.harness import ROOT, read_json


def claims_block(name: str):
    """The block ``name`` of workflows/paper/claims.py, rendered from its record claims.json
    (written by workflows/paper/reproduce.py)."""
    def block() -> str:
        if not CLAIMS.exists():
            return "(not measured yet: python workflows/paper/reproduce.py)\n"
        return claims_module().RENDER[name](read_json(CLAIMS))
    return block


def summary_keys() -> str:
    """docs/analysis.md's table of every summary key, from their declarations
    (bkflow.analysis.summary_keys)."""
    from bkflow.analysis.summary_keys import keys_table

    return keys_table() + "\n"


def _first_sentence(path: Path) -> str:
    """The first sentence of a module's docstring, in Markdown."""
    import ast

    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    first = " ".join(doc.split("\n\n")[0].split())
    # the first full stop that ends a sentence: not an abbreviation's, not inside a literal
    end = next((m.start() for m in re.finditer(r"\. (?=[A-Z])", first)
                if not re.search(r"(\bFig|\bal|\be\.g|\bi\.e|\bEq)$", first[:m.start()])
                and first[:m.start()].count("`") % 2 == 0), -1)
    # reStructuredText's literals as Markdown's
    return (first[:end + 1] if end >= 0 else first).replace("``", "`").replace("|", "\\|")


def layout() -> str:
    """docs/develop.md's table of the package: each group (its __init__'s words) and each of
    its modules (the first sentence of its docstring), in the layers' order of
    tests/test_house.py."""
    src = ROOT / "src" / "bkflow"
    rows = ["| group | module | what it does |", "|---|---|---|"]
    for group in ("model", "observables", "store", "lammps", "analysis", "sweeps", "figures",
                  "cli"):
        rows.append(f"| `{group}/` | | {_first_sentence(src / group / '__init__.py')} |")
        for path in sorted((src / group).glob("*.py")):
            if path.name != "__init__.py":
                rows.append(f"| | `{path.name}` | {_first_sentence(path)} |")
    for name in ("api.py", "slurm.py", "cluster.py"):
        rows.append(f"| `{name}` | | {_first_sentence(src / name)} |")
    return "\n".join(rows) + "\n"


#: the blocks this module makes, by name
BLOCKS = {"summary-keys": summary_keys, "layout": layout,
          **{name: claims_block(name) for name in (
              "claims-verdicts", "claims-1", "claims-4", "claims-5", "claims-6", "claims-other",
              "claims-scheme", "claims-sizes")}}
