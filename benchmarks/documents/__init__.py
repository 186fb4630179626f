"""The documents' numbers: the generated blocks of benchmarks/RESULTS.md,
workflows/paper/REPRODUCTION.md, docs/ (``results_blocks``) and README.md (``readme_numbers``),
each made from a record, and the check that every block is what its record gives.
"""
