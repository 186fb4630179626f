"""Reports over the records of benchmarks/measure/: tables, the figures beside RESULTS.md, and
what bkflow installs from the records (the switching calibration). A report runs no simulation.
"""
