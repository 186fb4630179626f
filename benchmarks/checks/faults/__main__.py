"""``python -m benchmarks.checks.faults``: the fault fuzz (benchmarks/checks/faults/fuzz.py)."""

from benchmarks.checks.faults.fuzz import main

raise SystemExit(main())
