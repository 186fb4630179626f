"""Measurements: each runs bkflow or LAMMPS and times or measures it, and prints a table or
writes a record into benchmarks/records/ (which benchmarks/report/ and benchmarks/documents/
read). ``python -m benchmarks.measure.NAME --help`` says what one measures and how long it runs.
"""
