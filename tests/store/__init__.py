"""Tests of the run and sweep directories on disk."""
