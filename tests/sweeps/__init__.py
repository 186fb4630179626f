"""Tests of local and SLURM sweeps."""
