"""Many runs: the grid of a sweep, its signac project and jobs, local execution and SLURM."""
