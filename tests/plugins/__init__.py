"""Tests of the C++ plugin against the NumPy reference integrator (tests/reference.py)."""
