"""The bkflow sweep as a signac-flow project: status, local runs and SLURM submission.

A thin example: the project ships inside the package, so ``python -m bkflow.slurm`` does
the same from any installation (a wheel too). Run either inside a sweep directory (one made
by ``bkflow sweep``; ``--init`` creates the jobs without running them):

    bkflow sweep --phi 1e-1:1e3 --sizes 100,400,900 --seeds 3 --out grid --init
    cd grid
    python -m bkflow.slurm status              # or: python ../workflows/project.py status
    python -m bkflow.slurm submit --bundle 16 --parallel --pretend   # see the scripts
    python -m bkflow.slurm submit --bundle 16 --parallel             # SLURM: sbatch
    bkflow collect .                                                 # runs.csv, results.csv
"""

from bkflow.slurm import main

if __name__ == "__main__":
    main()
