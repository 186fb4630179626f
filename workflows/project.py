"""The bkflow sweep as a signac-flow project: status, local runs and SLURM submission.

Run it from inside a sweep directory (one made by ``bkflow sweep``; ``--init`` creates the
jobs without running them):

    bkflow sweep --phi 1e-1:1e3 --sizes 100,400,900 --seeds 3 --out grid --init
    cd grid
    python ../workflows/project.py status                      # finished / eligible per job
    python ../workflows/project.py run --np 2                   # here, 2 at a time
    python ../workflows/project.py submit --bundle 16 --parallel --pretend   # see the script
    python ../workflows/project.py submit --bundle 16 --parallel             # SLURM: sbatch
    bkflow collect .                                            # runs.csv, results.csv

The project is :class:`bkflow.project.ClusterProject`, whose operations ``simulate`` and
``analyze`` are the ones ``bkflow sweep`` runs; its job-script template ships with the
package (``bkflow/templates/script.sh``).
"""

import os

from bkflow.project import ClusterProject

if __name__ == "__main__":
    ClusterProject.get_project(os.getcwd()).main()
