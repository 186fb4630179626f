"""``python -m benchmarks.checks.faults``: the fault fuzz (benchmarks/checks/faults/run.py)."""

from benchmarks.checks.faults.run import main

raise SystemExit(main())
