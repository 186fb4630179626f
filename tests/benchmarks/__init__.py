"""Tests of the benchmarks' checks: the normalizer of the CLI comparison."""
