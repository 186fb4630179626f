"""The run and sweep directories on disk: their layout and checks (rundir), the file formats
at bkflow's edge (formats), the sweep's tables and where a result came from (provenance)."""
