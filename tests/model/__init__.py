"""Tests of what a run is: parameters, presets, the time step, the starts."""
