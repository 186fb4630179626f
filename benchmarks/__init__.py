"""bkflow's benchmarks, by what each part does (run them from the repository's root, as
modules: ``python -m benchmarks.measure.throughput``):

- ``measure/``: runs bkflow or LAMMPS and times or measures it, printing a table or writing a
  record into ``records/``;
- ``report/``: reads the records (never runs a simulation) and prints their tables, draws
  their figures (the PNGs beside RESULTS.md) or writes what bkflow installs from them;
- ``documents/``: writes the generated blocks of RESULTS.md, README.md, docs/ and
  workflows/paper/REPRODUCTION.md from the records, and checks that they are current;
- ``checks/``: judges bkflow's behaviour (every fault ends clean, two plugin builds give the
  same bits, two sweeps agree), with a verdict rather than a number;
- ``harness.py``: what they share: their arguments, their timing and their records.
"""
