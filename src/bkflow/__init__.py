"""bkflow: the 2D Burridge-Knopoff friction model of Giacco et al. (Sci. Rep. 2014) on LAMMPS."""

__version__ = "0.6.0"


def __getattr__(name):
    # bkflow.load_run / bkflow.load_sweep (bkflow.api) without importing pandas and matplotlib
    # for every user of the package (the engine, the command line)
    if name in ("load_run", "load_sweep", "Run", "Sweep"):
        from bkflow import api

        return getattr(api, name)
    raise AttributeError(f"module 'bkflow' has no attribute {name!r}")


def __dir__():
    return ["__version__", "load_run", "load_sweep", "Run", "Sweep"]
