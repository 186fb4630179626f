"""The fault fuzz: bkflow run as a user would, with bad inputs and faults, every case judged
CLEAN or not (``python -m benchmarks.checks.faults``; its record benchmarks/records/faults.json
fills RESULTS.md's table).
"""
