"""``python -m bkflow.slurm``: the stable name of the sweep-on-a-SLURM-cluster command, which
the job scripts of a submitted sweep call. The command itself is ``bkflow.sweeps.slurm``.
(``python -m bkflow.cluster``, its name before bkflow 0.6, still runs it: job scripts
submitted before call it.)"""

from bkflow.sweeps.slurm import main, project  # noqa: F401

if __name__ == "__main__":
    main()
