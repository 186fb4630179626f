"""Tests of the figures of bkflow plot."""
