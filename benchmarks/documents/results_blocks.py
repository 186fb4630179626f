"""The generated blocks of benchmarks/RESULTS.md, workflows/paper/REPRODUCTION.md and
docs/analysis.md and docs/develop.md: every number there that comes from a benchmark's
records, the table of the summary's keys (from bkflow.analysis.summary_keys) and the package's
layout, is written by a function of this folder, between ``<!-- generated: NAME -->`` and
``<!-- end -->``.

    python -m benchmarks.documents.results_blocks            # check: exit 1 when a block differs
    python -m benchmarks.documents.results_blocks --write    # (re)write every block

``tests/test_results_blocks.py`` makes the same check, so that a document cannot drift from
its records. The blocks, by the section of RESULTS.md they fill: ``speed``, ``accuracy``,
``stiff_end``, ``steady`` and ``robustness``; ``pages`` those of the other pages.
"""

from __future__ import annotations

import re
import sys

from benchmarks.documents import accuracy, pages, robustness, speed, steady, stiff_end
from benchmarks.harness import BENCH, ROOT, parser

DOCUMENTS = (BENCH / "RESULTS.md", ROOT / "workflows" / "paper" / "REPRODUCTION.md",
             ROOT / "docs" / "analysis.md", ROOT / "docs" / "develop.md")
BLOCK = re.compile(r"(<!-- generated: ([\w-]+) -->\n)(.*?)(<!-- end -->)", re.S)
#: every block by its name: the function that makes its text
BLOCKS = {**speed.BLOCKS, **accuracy.BLOCKS, **stiff_end.BLOCKS, **steady.BLOCKS,
          **robustness.BLOCKS, **pages.BLOCKS}


def render(text: str) -> str:
    """``text`` with every generated block it holds made anew."""
    def fill(m):
        name = m.group(2)
        if name not in BLOCKS:
            return m.group(0)
        return m.group(1) + BLOCKS[name]() + m.group(4)

    return BLOCK.sub(fill, text)


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    stale = []
    for doc in DOCUMENTS:
        old = doc.read_text()
        new = render(old)
        if new != old:
            if a.write:
                doc.write_text(new)
                print(f"wrote {doc}")
            else:
                stale.append(str(doc))
    for s in stale:
        print(f"{s}: a generated block differs from its records; run "
              "python -m benchmarks.documents.results_blocks --write", file=sys.stderr)
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
