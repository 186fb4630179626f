"""Tests of running LAMMPS: the plugin's loading, paths, continuation, scenes, the stop rule."""
