"""``python -m bkflow.cluster``: the old name of ``python -m bkflow.slurm`` (the sweep on a
SLURM cluster), kept so that job scripts submitted before it was renamed still run; "cluster"
in bkflow now means the slip clusters only."""

from bkflow.sweeps.slurm import main, project  # noqa: F401

if __name__ == "__main__":
    main()
