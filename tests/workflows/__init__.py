"""Tests of the paper's workflow: claims and its own figures."""
