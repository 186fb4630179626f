"""Tests of the registry of the summary's keys."""
