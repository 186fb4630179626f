"""``python -m bkflow.cluster``: the stable name of the sweep-on-a-cluster command, which the
job scripts of a submitted sweep call. The command itself is ``bkflow.sweeps.slurm``."""

from bkflow.sweeps.slurm import main, project  # noqa: F401

if __name__ == "__main__":
    main()
