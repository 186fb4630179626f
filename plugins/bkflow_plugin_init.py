"""Compiled bkflow LAMMPS plugin (bkflowplugin.so) and the LAMMPS build it targets."""
