"""Tests of the pure numerics on series whose answers are known."""
