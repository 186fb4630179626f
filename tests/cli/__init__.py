"""Tests of the command line: commands and every class of fault."""
