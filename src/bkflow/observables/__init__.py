"""Pure array numerics of a run's series: stress drops and friction, stationarity, the
contacts' phases, bond order, slip clusters, the event catalogue, the long-lived states and
the in-run reduction's mirror. No files, no LAMMPS: arrays in, arrays and dataclasses out."""
