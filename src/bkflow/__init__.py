"""bkflow: the 2D Burridge-Knopoff friction model of Giacco et al. (Sci. Rep. 2014) on LAMMPS."""

__version__ = "0.1.0"
