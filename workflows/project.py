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

The operation is ``simulate`` of :mod:`bkflow.sweep`, the same function ``bkflow sweep``
runs: one job = one RunSpec, post-condition "finished" (files intact and analysed), so a
re-submission skips finished runs. Each operation asks for one core (``np = 1``) and a
wall time estimated from the run's atom-steps; ``--bundle K --parallel`` packs K runs into
one SLURM job of K tasks. The job script is flow's SLURM template extended by
``templates/script.sh`` beside this file (see the comments there).
"""

import os
from pathlib import Path

from bkflow.sweep import SweepProject


class Project(SweepProject):
    """SweepProject with the cluster template of workflows/templates."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # flow looks for templates in <sweep dir>/templates; ours lives beside this file so
        # that every sweep directory uses it without a copy
        self._template_dir = str(Path(__file__).resolve().parent / "templates")


if __name__ == "__main__":
    Project.get_project(os.getcwd()).main()
